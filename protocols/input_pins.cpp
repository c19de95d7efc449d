#include "protocols/input_pins.hpp"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "results/sha256.hpp"

namespace palplab::protocols {

namespace fs = std::filesystem;

namespace {

bool read(const fs::path& p, std::string& out) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  out = ss.str();
  return true;
}

}  // namespace

std::string prototype_sha256(const std::string& prototype_path) {
  std::string text;
  if (!read(prototype_path, text)) return results::sha256_hex(prototype_path);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return results::sha256_hex(text);
  const auto m = j.find("mesh");
  if (m == j.end() || !m->is_object()) return results::sha256_hex(text);
  const auto f = m->find("file");
  if (f == m->end() || !f->is_string()) return results::sha256_hex(text);
  fs::path mesh(f->get<std::string>());
  if (mesh.is_relative()) mesh = fs::path(prototype_path).parent_path() / mesh;
  std::vector<fs::path> files;
  const std::string ext = mesh.extension().string();
  if (ext == ".node" || ext == ".ele" || ext.empty()) {
    for (const char* e : {".node", ".ele", ".names"})
      files.push_back(fs::path(mesh).replace_extension(e));
  } else {
    files.push_back(mesh);
  }
  std::string all = text;
  for (const auto& p : files) {
    std::string content;
    all += "\nmesh " + p.filename().string() + " ";
    all += read(p, content) ? results::sha256_hex(content) : "unreadable";
  }
  return results::sha256_hex(all);
}

}  // namespace palplab::protocols
