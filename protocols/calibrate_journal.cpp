#include "protocols/calibrate_journal.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/input_error.hpp"
#include "common/read_file.hpp"
#include "palplab/version.hpp"
#include "protocols/input_pins.hpp"
#include "results/sha256.hpp"

namespace palplab::protocols {

namespace {

constexpr const char* kTag = "palplab_calibration_eval";

// Which palplab wrote a line (said, not part of the set-up: the start's check decides).
std::string palplab_build() {
  return std::string(kVersion) + " " + kGitCommit;
}

// Exact in JSON: finite doubles as numbers (written to round-trip), the others as text.
nlohmann::json enc(double x) {
  if (std::isfinite(x)) return x;
  return std::isnan(x) ? "nan" : (x > 0 ? "inf" : "-inf");
}
bool dec(const nlohmann::json& j, double& x) {
  if (j.is_number()) {
    x = j.get<double>();
    return true;
  }
  if (!j.is_string()) return false;
  const std::string s = j.get<std::string>();
  if (s == "nan")
    x = std::numeric_limits<double>::quiet_NaN();
  else if (s == "inf")
    x = std::numeric_limits<double>::infinity();
  else if (s == "-inf")
    x = -std::numeric_limits<double>::infinity();
  else
    return false;
  return true;
}

}  // namespace

std::string calibration_setup(const Study& study, int sim_n, const std::vector<std::string>& keys,
                              const std::vector<HumanCell>& used) {
  nlohmann::json j;
  j["study_sha256"] = results::sha256_hex(study.json_text);
  j["sim_n"] = sim_n;
  j["keys"] = keys;
  // The prototypes as simulated (their files and meshes): a changed one changes every loss.
  for (const auto& [id, file] : study.prototype_files) j["prototypes"][id] = prototype_sha256(file);
  nlohmann::json cells = nlohmann::json::array();
  for (const auto& c : used) {
    nlohmann::json v = nlohmann::json::array();
    for (double x : c.values) v.push_back(enc(x));
    cells.push_back({c.group, c.phase, c.session, c.measure, c.undefined, v});
  }
  j["cells"] = cells;
  return results::sha256_hex(j.dump());
}

bool is_calibration_journal(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string first;
  std::getline(in, first);
  const auto j = nlohmann::json::parse(first, nullptr, false);
  if (!j.is_discarded() && j.is_object() && j.contains(kTag)) return true;
  // Its first line cut by an interruption (no newline yet): a line as append() writes it starts
  // so (nlohmann orders the keys).
  return in.eof() && first.rfind("{\"cells\":[", 0) == 0;
}

CalibrationJournal::CalibrationJournal(const std::string& path, const std::string& setup,
                                       const std::vector<HumanCell>& used)
    : path_(path), setup_(setup) {
  // A device or a FIFO would be read without end (/dev/zero) or block (a FIFO).
  std::error_code ec0;
  const auto st = std::filesystem::status(path, ec0);
  if (std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
    throw InputError(SourceLocation{"--journal"},
                     "\"" + path +
                         "\" is not a regular file (a directory, a FIFO or a device); expected "
                         "the journal's file (or /dev/null for none)");
  // Opened (created) and locked before it is read: a second calibrate on the same journal would
  // simulate the same points and interleave its lines with the first's.
  errno = 0;
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0)
    throw InputError(std::string("cannot write the journal (") + std::strerror(errno) + ")", path);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(::fdopen(fd, "ab"), &std::fclose);
  if (!file) {
    const int why = errno;
    ::close(fd);
    throw InputError(std::string("cannot write the journal (") + std::strerror(why) + ")", path);
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int why = errno;
    throw InputError(
        SourceLocation{"--journal"},
        "\"" + path + "\" is in use: " +
            (why == EWOULDBLOCK ? std::string("another palplab calibrate is running this fit; wait "
                                              "for it to end (it is resumed from the journal by "
                                              "the same command) or give another --journal")
                                : std::string("it cannot be locked (") + std::strerror(why) + ")"));
  }
  // A line is a few kB (its cells); 256 MiB is tens of thousands of evaluations, far beyond any
  // --budget, and keeps a runaway file from being read until memory runs out.
  constexpr std::size_t kMaxJournalBytes = std::size_t{256} << 20;
  std::string text = read_file_bounded(path, kMaxJournalBytes, "calibration journal");
  // A last line without its newline was cut by an interruption: cut off (its evaluation is
  // simulated again).
  const std::size_t complete = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  if (complete < text.size()) {
    std::error_code ec;
    std::filesystem::resize_file(path, complete, ec);
    if (ec)
      throw InputError("cannot cut the journal's incomplete last line (" + ec.message() + ")",
                       path);
    text.resize(complete);
  }
  std::istringstream lines(text);
  std::string line;
  int at = 0;
  while (std::getline(lines, line)) {
    ++at;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // a blank line
    const auto j = nlohmann::json::parse(line, nullptr, false);
    auto bad = [&](const std::string& why) {
      throw InputError(SourceLocation{path, at},
                       "not a calibration evaluation (" + why +
                           "); the journal holds the evaluations palplab calibrate wrote: give "
                           "another --journal, or remove the file to start the fit afresh");
    };
    if (j.is_discarded() || !j.is_object() || !j.contains(kTag)) bad("not such a JSON line");
    if (!j.contains("setup") || !j["setup"].is_string()) bad("no setup");
    if (j["setup"].get<std::string>() != setup) continue;  // another fit's
    std::vector<double> x;
    double loss = 0;
    if (!j.contains("x") || !j["x"].is_array() || !j.contains("loss") || !dec(j["loss"], loss))
      bad("no x or loss");
    for (const auto& v : j["x"]) {
      double d = 0;
      if (!dec(v, d) || !std::isfinite(d)) bad("x holds " + v.dump() + ": parameters are finite");
      x.push_back(d);
    }
    const auto& cells = j.value("cells", nlohmann::json::array());
    if (!cells.is_array() || cells.size() != used.size()) bad("its cells are not the fit's");
    std::vector<CellFit> fit;
    for (std::size_t i = 0; i < used.size(); ++i) {
      const auto& c = cells[i];
      CellFit f;
      f.human = used[i];
      if (!c.is_array() || c.size() != 6 || !c[0].is_number_integer() ||
          !c[1].is_number_integer() || !dec(c[2], f.mean) || !dec(c[3], f.sd) ||
          !dec(c[4], f.z_mean) || !dec(c[5], f.z_sd))
        bad("cell " + std::to_string(i) + " is " + c.dump());
      f.n_sim = c[0].get<int>();
      f.undefined = c[1].get<int>();
      if (f.n_sim < 0 || f.undefined < 0 || f.n_sim + f.undefined == 0)
        bad("cell " + std::to_string(i) + " counts " + c[0].dump() + " and " + c[1].dump() +
            " participants");
      // Its z-scores are its mean's and SD's against the human cell (an edited z, or a mean
      // edited without its z, would steer the fit; so would a mean beside fewer than 2 values).
      CellFit z = f;
      set_cell_z(z);
      const auto same = [](double a, double b) {
        return a == b || (std::isnan(a) && std::isnan(b));
      };
      if ((f.n_sim < 2 && !(std::isnan(f.mean) && std::isnan(f.sd))) || !same(z.z_mean, f.z_mean) ||
          !same(z.z_sd, f.z_sd))
        bad("cell " + std::to_string(i) + "'s z-scores " + c[4].dump() + ", " + c[5].dump() +
            " are not those of its mean " + c[2].dump() + " and SD " + c[3].dump() + " (" +
            nlohmann::json(z.z_mean).dump() + ", " + nlohmann::json(z.z_sd).dump() + ")");
      fit.push_back(std::move(f));
    }
    // The loss is its cells' (an edited loss or cell would steer the fit).
    double recomputed = 0.0;
    for (const auto& f : fit) add_cell_loss(recomputed, f);
    if (!(recomputed == loss || (std::isnan(recomputed) && std::isnan(loss))))
      bad("its loss " + j["loss"].dump() + " is not its cells' (" +
          nlohmann::json(recomputed).dump() + ")");
    if (j.value("palplab", std::string()) != palplab_build()) ++other_build_;
    stored_.emplace(std::move(x), std::make_pair(loss, std::move(fit)));
  }
  file_ = file.release();  // appends at the end (O_APPEND), after the cut above
}

CalibrationJournal::~CalibrationJournal() {
  if (file_) std::fclose(file_);
}

const std::pair<double, std::vector<CellFit>>* CalibrationJournal::find(
    const std::vector<double>& x) const {
  const auto it = stored_.find(x);
  return it == stored_.end() ? nullptr : &it->second;
}

void CalibrationJournal::append(const std::vector<double>& x, double loss,
                                const std::vector<CellFit>& fit) {
  nlohmann::json j;
  j[kTag] = 1;
  j["setup"] = setup_;
  j["palplab"] = palplab_build();
  nlohmann::json xs = nlohmann::json::array();
  for (double v : x) xs.push_back(enc(v));
  j["x"] = xs;
  j["loss"] = enc(loss);
  nlohmann::json cells = nlohmann::json::array();
  for (const auto& f : fit)
    cells.push_back({f.n_sim, f.undefined, enc(f.mean), enc(f.sd), enc(f.z_mean), enc(f.z_sd)});
  j["cells"] = cells;
  const std::string line = j.dump() + "\n";
  errno = 0;
  if (std::fwrite(line.data(), 1, line.size(), file_) != line.size() || std::fflush(file_) != 0)
    throw InputError(std::string("cannot write the journal (") +
                         (errno ? std::strerror(errno) : "a write failed") +
                         "); the evaluations before this one are kept: make room and run the "
                         "same command again, it resumes",
                     path_);
}

}  // namespace palplab::protocols
