// `palplab calibrate STUDY.json --human FILE.csv --params KEYS... [--bounds NAME=LO:HI...]
//                    [--budget N] [--jobs N] [--sim-n N] --out PARAMS.json`: fits the named
//                    trainee-model parameters to
// human data by Nelder–Mead with restarts over a simulated-moments loss with common random
// numbers (protocols/calibrate.hpp); prints the fitted values with standard errors, the loss
// before and after, and the fit per group and measure; writes them all to PARAMS.json (its
// "participant_model" object can be pasted into a study).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/json_locate.hpp"
#include "common/write_file.hpp"
#include "protocols/calibrate.hpp"
#include "protocols/calibrate_journal.hpp"
#include "protocols/study.hpp"

namespace {
struct CalibrateArgs {
  std::string study, human, out, write_defaults, journal;
  palplab::protocols::CalibrateOptions opt;
  std::vector<std::string> bounds;  // --bounds NAME=LO:HI, parsed into opt.bounds
  bool quiet = false;
  bool no_se = false;
  bool overwrite = false;  // replace an --out that is not a calibration JSON
};

palplab::app::CommandRegistration reg_calibrate{
    "calibrate", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("calibrate",
                                      "Fit participant-model parameters to human data (tidy CSV)");
      auto a = std::make_shared<CalibrateArgs>();
      cmd->add_option("STUDY", a->study, "Study file (JSON) that produced the human data")
          ->required();
      cmd->add_option("--human", a->human,
                      "Human data: CSV with participant,group,phase,session,measure,value")
          ->required();
      cmd->add_option("--params", a->opt.keys, "Trainee parameters to fit (names)")
          ->required()
          ->expected(1, -1);
      cmd->add_option("--bounds", a->bounds,
                      "This fit's bounds of fitted parameters, NAME=LO:HI each (within the "
                      "parameter's own bounds; default: those)")
          ->expected(1, -1);
      cmd->add_option("--budget", a->opt.budget,
                      "Loss evaluations for the optimiser (each simulates the study once at "
                      "--sim-n per group)")
          ->capture_default_str()
          ->check(palplab::app::count_range(1, 1000000));
      cmd->add_option("--jobs", a->opt.jobs, "Participants simulated in parallel (threads)")
          ->check(palplab::app::count_range(1, 1024));
      cmd->add_option("--sim-n", a->opt.sim_n,
                      "Simulated participants per group (default: the study's group sizes)")
          ->check(palplab::app::count_range(2, 100000));
      cmd->add_option("--measures", a->opt.measures,
                      "Measures to fit (default: the study's declared measures)")
          ->expected(1, -1);
      cmd->add_option("--out", a->out, "Where to write the fitted parameters (JSON)")->required();
      auto* defaults_opt =
          cmd->add_option("--write-defaults", a->write_defaults,
                          "Also write the fitted values as the defaults into this params.hpp "
                          "(protocols/participants/params.hpp; rebuild afterwards)");
      auto* journal_opt = cmd->add_option(
          "--journal", a->journal,
          "Where every evaluation is written as it finishes (default: next to --out, "
          "PARAMS.evals.jsonl); the same command resumes an interrupted fit from it");
      cmd->add_flag("--quiet", a->quiet, "No progress output");
      cmd->add_flag("--overwrite", a->overwrite,
                    "Replace an existing --out that is not a calibration JSON");
      cmd->add_flag("--no-se", a->no_se,
                    "Skip the standard errors (saves the 2p² simulations of the curvature)");
      cmd->callback([a, defaults_opt, journal_opt, code] {
        using namespace palplab::protocols;
        a->opt.bounds.clear();
        for (const auto& b : a->bounds) a->opt.bounds.push_back(parse_bound(b));
        Study s = load_study(a->study, engine_prototype_inspector());
        if (a->human.empty())
          throw palplab::InputError(palplab::SourceLocation{"--human"},
                                    "expected the people's CSV file, got an empty path");
        auto cells = read_human_cells(a->human);
        // The outputs are checked before the fit (which takes minutes to hours).
        const bool defaults = defaults_opt->count() > 0;
        if (defaults && a->write_defaults.empty())
          throw palplab::InputError(palplab::SourceLocation{"--write-defaults"},
                                    "expected the path of the participant model's params.hpp "
                                    "(protocols/participants/params.hpp), got an empty string");
        // --out is never an input (nor the params.hpp the defaults go into), nor a file of
        // another kind without --overwrite.
        std::vector<palplab::app::CommandInput> not_out = {{"the study file", a->study},
                                                           {"the human data", a->human}};
        for (const auto& [id, file] : s.prototype_files)
          not_out.push_back({"prototype " + id + " of the study", file});
        if (defaults) not_out.push_back({"the --write-defaults file", a->write_defaults});
        // A calibration JSON cut off or edited into invalid JSON was refused as "a JSON file,
        // not a palplab calibration JSON" (review 2026-12-07): a file that starts as JSON and
        // does not parse is said to be damaged, with where it breaks (palplab writes the keys
        // sorted, so a cut one has mostly lost "palplab_calibration").
        std::error_code size_ec;
        if (!a->overwrite && std::filesystem::is_regular_file(a->out) &&
            std::filesystem::file_size(a->out, size_ec) <= palplab::json::kMaxJsonFileBytes &&
            !size_ec) {
          const std::string text =
              palplab::app::file_head(a->out, palplab::json::kMaxJsonFileBytes);
          const auto first = text.find_first_not_of(" \t\r\n");
          if (first != std::string::npos && (text[first] == '{' || text[first] == '[')) try {
              (void)palplab::json::parse_located(text, a->out);
            } catch (const palplab::InputError& e) {
              const bool ours = text.find("\"palplab_calibration\"") != std::string::npos;
              throw palplab::InputError(
                  palplab::SourceLocation{"--out"},
                  "\"" + a->out + "\" " +
                      (ours ? "looks like a palplab calibration JSON but is damaged ("
                            : "exists and is not valid JSON (") +
                      e.what() + ")" +
                      (ours ? "" : ": a damaged file, perhaps a calibration JSON cut off") +
                      "; refusing to replace it: repair it, choose another --out, or give "
                      "--overwrite to replace it");
            }
        }
        palplab::app::require_replaceable_output(
            "--out", a->out, not_out,
            [](const std::string& p) {
              std::ifstream in(p, std::ios::binary);
              const auto j = nlohmann::json::parse(in, nullptr, false);
              return !j.is_discarded() && j.is_object() && j.contains("palplab_calibration");
            },
            "palplab calibration JSON", a->overwrite);
        // The journal: next to --out unless given (/dev/null: none); never an input or --out; a
        // file of another kind only with --overwrite (then removed: the journal is appended to
        // and read back).
        if (journal_opt->count() > 0 && a->journal.empty())
          throw palplab::InputError(palplab::SourceLocation{"--journal"},
                                    "expected where to write the evaluations, got an empty path");
        if (a->journal.empty())
          a->journal = std::filesystem::path(a->out).replace_extension(".evals.jsonl").string();
        auto same_path = [](const std::string& x, const std::string& y) {
          std::error_code e1, e2;
          const auto cx = std::filesystem::weakly_canonical(std::filesystem::absolute(x), e1);
          const auto cy = std::filesystem::weakly_canonical(std::filesystem::absolute(y), e2);
          return !e1 && !e2 && cx == cy;
        };
        if (same_path(a->journal, a->out))
          throw palplab::InputError(palplab::SourceLocation{"--journal"},
                                    "\"" + a->journal +
                                        "\" is --out too (the fitted parameters go there); "
                                        "expected another file for the evaluations");
        // The outputs written through FILE.partial (common/write_file) must not be one another:
        // --out at the defaults' PARAMS.partial was renamed away after the fit, exit 0; the
        // journal at --out's or the defaults' .partial ended hours of fitting in exit 2
        // (review 2026-12-06, fifth).
        {
          std::vector<std::pair<std::string, std::string>> through = {{"--out", a->out}};
          if (defaults) through.push_back({"--write-defaults", a->write_defaults});
          const std::vector<std::pair<std::string, std::string>> others = {
              {"--out", a->out}, {"--journal", a->journal}};
          for (const auto& [flag, file] : through)
            for (const auto& [oflag, other] : others)
              if (flag != oflag && same_path(other, file + ".partial"))
                throw palplab::InputError(
                    palplab::SourceLocation{oflag},
                    "\"" + other + "\" is where " + flag + " (" + file +
                        ") is written first, then renamed, which would take it away: choose "
                        "another " +
                        oflag);
        }
        if (same_path(a->journal, "/dev/null")) {
          a->journal.clear();  // no journal (the fit is not resumable)
        } else {
          palplab::app::require_replaceable_output(
              "--journal", a->journal, not_out,
              [](const std::string& p) { return palplab::protocols::is_calibration_journal(p); },
              "palplab calibration journal", a->overwrite);
          std::error_code ec;
          if (a->overwrite && std::filesystem::is_regular_file(a->journal, ec) &&
              !palplab::protocols::is_calibration_journal(a->journal))
            std::filesystem::remove(a->journal, ec);
        }
        a->opt.journal = a->journal;
        if (!a->write_defaults.empty()) {
          namespace fs = std::filesystem;
          std::error_code ec;
          const auto type = fs::status(a->write_defaults, ec).type();
          if (type != fs::file_type::regular)
            throw palplab::InputError(
                palplab::SourceLocation{"--write-defaults"},
                (type == fs::file_type::not_found || type == fs::file_type::none
                     ? "no file \"" + a->write_defaults + "\""
                     : "\"" + a->write_defaults + "\" is " +
                           (type == fs::file_type::directory ? std::string("a directory")
                            : type == fs::file_type::fifo    ? std::string("a FIFO")
                            : type == fs::file_type::socket  ? std::string("a socket")
                                                             : std::string("not a regular file"))) +
                    " (expected the participant model's params.hpp, "
                    "protocols/participants/params.hpp, which the fitted defaults are written "
                    "into)");
          // It is rewritten through PARAMS.partial (common/write_file): an input there would be
          // destroyed after the fit.
          if (const auto* in = palplab::app::same_input(a->write_defaults + ".partial", not_out))
            palplab::app::refuse_input_output(
                "--write-defaults", a->write_defaults + ".partial", *in,
                "writing the fitted defaults into " + a->write_defaults +
                    " (written there first, then renamed)");
          palplab::app::require_writable_file("--write-defaults", a->write_defaults);
          // Its content too: a file write_defaults cannot edit would end a long fit in an error.
          try {
            check_defaults_file(a->opt.keys, a->write_defaults);
          } catch (const palplab::InputError& e) {
            throw palplab::InputError(palplab::SourceLocation{"--write-defaults"},
                                      std::string(e.what()) +
                                          " (expected the participant model's params.hpp, "
                                          "protocols/participants/params.hpp, with a member "
                                          "initialiser for every --params name)");
          }
        }
        a->opt.standard_errors = !a->no_se;
        a->opt.warning = [](const std::string& w) {
          std::cerr << "warning: --human: " << w << "\n";
        };
        if (!a->quiet)
          a->opt.notice = [](const std::string& m) {
            std::fprintf(stderr, "calibrate: %s\n", m.c_str());
          };
        if (!a->quiet)
          a->opt.progress = [keys = a->opt.keys](int e, double l, double best,
                                                 const std::vector<double>& x, bool stencil,
                                                 bool from_journal) {
            std::string at;
            for (std::size_t i = 0; i < x.size(); ++i)
              at += " " + keys[i] + "=" + std::to_string(x[i]);
            std::fprintf(stderr, "evaluation %d%s%s: loss %.4g (%s %.4g) at%s\n", e,
                         stencil ? " (SE stencil)" : "", from_journal ? " (from the journal)" : "",
                         l, stencil ? "fit" : "best", best, at.c_str());
          };
        CalibrationResult r = calibrate(s, cells, a->opt);
        auto j = to_json(r);
        j["study"] = a->study;
        j["human"] = a->human;
        j["sim_n"] = a->opt.sim_n;
        j["budget"] = a->opt.budget;
        // A calibration JSON already at --out is replaced (re-running a fit is the workflow)
        // and stderr says what it held. It is kept beside, never lost, unless it was a fit of
        // the same setup (study, human data, --sim-n, parameters, fitted cells) with no lower
        // loss: a fit of another setup, or a better one, goes to NAME.previous.json (the first
        // free NAME.previous-K.json when that exists). A fit of 20 evaluations was silently
        // replaced by a run of --budget 1, and an older .previous.json overwritten (reviews
        // 2026-12-07).
        std::string replaced;
        bool kept = false;
        {
          std::ifstream in(a->out, std::ios::binary);
          const auto old = in ? nlohmann::json::parse(in, nullptr, false) : nlohmann::json();
          if (old.is_object() && old.contains("palplab_calibration")) {
            const auto loss = old.value("loss_after", nlohmann::json());
            std::string held = "a fit";
            if (old.contains("fitted") && old["fitted"].is_object()) {
              held += " of";
              for (const auto& [k, v] : old["fitted"].items()) held += " " + k;
            }
            if (loss.is_number())
              held += " with loss " + palplab::json::Checker::fmt(loss.get<double>());
            auto cells = [](const nlohmann::json& f) {
              std::set<std::string> c;
              if (f.is_array())
                for (const auto& x : f)
                  if (x.is_object())
                    c.insert(x.value("group", "") + "/" + x.value("phase", "") + "/" +
                             x.value("session", nlohmann::json()).dump() + "/" +
                             x.value("measure", ""));
              return c;
            };
            const bool same_setup =
                old.value("study", "") == a->study && old.value("human", "") == a->human &&
                old.value("sim_n", nlohmann::json()) == j["sim_n"] &&
                old.value("fitted", nlohmann::json()).is_object() &&
                [&] {
                  std::set<std::string> keys;
                  for (const auto& [k, v] : old["fitted"].items()) keys.insert(k);
                  return keys == std::set<std::string>(a->opt.keys.begin(), a->opt.keys.end());
                }() &&
                cells(old.value("fit_after", nlohmann::json())) == cells(j["fit_after"]);
            const bool better = loss.is_number() && std::isfinite(r.loss_after) &&
                                loss.get<double>() < r.loss_after;
            if (!same_setup || better) {
              std::filesystem::path keep =
                  std::filesystem::path(a->out).replace_extension(".previous.json");
              std::error_code ec;
              for (int k = 2; std::filesystem::exists(keep, ec) && k < 10000; ++k)
                keep = std::filesystem::path(a->out).replace_extension(".previous-" +
                                                                       std::to_string(k) + ".json");
              palplab::write_file(keep.string(), old.dump(2) + "\n", "the replaced fit");
              kept = better;
              replaced = "replaced " + a->out + ": it held " + held +
                         (!same_setup ? " of another setup (study, human data, --sim-n, "
                                        "parameters or fitted cells: its loss is not comparable)"
                                      : ", lower than this fit's " +
                                            palplab::json::Checker::fmt(r.loss_after)) +
                         "; it is kept as " + keep.string();
            } else {
              replaced = "replaced " + a->out + ": it held " + held;
            }
          }
        }
        palplab::write_file(a->out, j.dump(2) + "\n", "the parameter file");
        if (!replaced.empty())
          std::cerr << (kept ? "warning: " : "") << palplab::escape_controls(replaced, false)
                    << "\n";
        std::cout << to_text(r) << "wrote " << a->out << "\n";
        if (!a->write_defaults.empty()) {
          write_defaults(r, a->write_defaults);
          std::cout << "wrote the fitted defaults into " << a->write_defaults
                    << " (rebuild to ship them)\n";
        }
        *code = 0;
      });
    }};
}  // namespace
