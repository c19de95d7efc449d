#include "app/scene_option.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "common/input_error.hpp"
#include "engine/haptics/scene_file.hpp"
#include "protocols/resolve.hpp"
#include "prototypes/factory.hpp"

namespace palplab::app {

namespace fs = std::filesystem;

CLI::Option* add_scene_option(CLI::App* cmd, std::vector<std::string>& scenes, bool many) {
  auto* o = cmd->add_option("--scene", scenes,
                            many ? "Simulation file (.psim, `palplab scene build`) whose "
                                   "precomputation the study's scenes start from (repeatable)"
                                 : "Simulation file (.psim, `palplab scene build`) or prototype "
                                   "key (A, B, C, D, ...) instead of the prototype file");
  // A vector option takes every following argument by default; one value per --scene.
  o->allow_extra_args(false);
  if (!many) o->expected(1);
  return o;
}

bool has_scene_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  return in.read(magic, 8) && std::memcmp(magic, "PALPSIM\0", 8) == 0;
}

bool is_scene_file(const std::string& value) {
  if (fs::path(value).extension() == ".psim") return true;
  return has_scene_magic(value);
}

void refuse_directory_as_scene(const std::string& label, const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError(label + ": is a directory, expected a .psim scene file");
}

namespace {

std::string load_psim(const std::string& file) {
  return engine::load_scene_file(file, prototypes::load_prototype).source;
}

std::string canonical(const std::string& p) {
  std::error_code ec;
  const fs::path c = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? fs::absolute(p).lexically_normal().string() : c.string();
}

}  // namespace

std::string scene_prototype(const std::string& positional, const std::vector<std::string>& scenes) {
  if (scenes.empty()) {
    if (positional.empty()) throw InputError("give a prototype file or --scene FILE.psim|KEY");
    return positional;
  }
  const std::string& v = scenes.front();
  std::string proto;
  std::error_code ec;
  if (fs::is_directory(v, ec)) {
    // A prototype key is a name, never a path; a directory of that name in the working
    // directory does not hide the shipped prototype.
    if (fs::path(v).extension() != ".psim")
      proto = protocols::resolve_prototype(v, protocols::prototype_search_dirs("", {}));
    if (proto.empty())
      throw InputError("--scene \"" + v +
                       "\": is a directory, expected a .psim scene file (or a prototype key: A, B, "
                       "C, D, ...)");
  } else if (is_scene_file(v)) {
    proto = load_psim(v);
  } else {
    proto = protocols::resolve_prototype(v, protocols::prototype_search_dirs("", {}));
    if (proto.empty())
      throw InputError("--scene \"" + v +
                       "\": neither a .psim file nor a known prototype key (A, B, C, D, ...)");
  }
  if (!positional.empty() && canonical(positional) != canonical(proto))
    throw InputError("--scene " + v + " is prototype " + proto + ", not " + positional +
                     " (give one of them)");
  return proto;
}

std::vector<std::string> preload_scenes(const std::vector<std::string>& scenes) {
  std::vector<std::string> sources;
  for (const auto& v : scenes) {
    refuse_directory_as_scene("--scene \"" + v + "\"", v);
    if (!is_scene_file(v))
      throw InputError("--scene \"" + v +
                       "\": run takes simulation files (.psim); the study names its prototypes");
    sources.push_back(load_psim(v));
  }
  return sources;
}

std::vector<std::string> unused_scene_warnings(const std::vector<std::string>& scenes,
                                               const std::vector<std::string>& sources,
                                               const std::vector<std::string>& used) {
  std::vector<std::string> out;
  std::set<std::string> used_files, seen;
  std::map<std::string, std::string> scene_of_source;  // prototype file -> first --scene of it
  for (const auto& u : used) used_files.insert(canonical(u));
  for (std::size_t i = 0; i < scenes.size() && i < sources.size(); ++i) {
    if (!seen.insert(canonical(scenes[i])).second) {
      out.push_back("warning: --scene \"" + scenes[i] +
                    "\" is given more than once (it is used once)");
      continue;
    }
    const auto [first, fresh] = scene_of_source.emplace(canonical(sources[i]), scenes[i]);
    if (!fresh) {
      out.push_back("warning: --scene \"" + scenes[i] +
                    "\" was built from the same prototype as --scene \"" + first->second + "\" (" +
                    sources[i] + "): both hold its precomputation, one of them is enough");
      continue;
    }
    if (!used_files.count(canonical(sources[i])))
      out.push_back("warning: --scene \"" + scenes[i] + "\" was built from " + sources[i] +
                    ", a prototype this study does not use: it has no effect on the run");
  }
  return out;
}

}  // namespace palplab::app
