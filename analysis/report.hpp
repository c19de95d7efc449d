#pragma once
// The study report: `palplab report DB --out DIR` writes DIR/report.md, a self-contained
// DIR/report.html (inline CSS and SVG, no scripts, no network) and DIR/figures/*.svg, from a
// results store (results/, schema 2: the study structure — groups, phase kinds, cues,
// thresholds — comes from its tables; schema-1 databases are refused with InputError).
// Sections: study description, provenance and the phases as run; the study's declared
// hypotheses (confirmatory, run first), then, labelled exploratory, per declared analysis
// (measure × phase, pooled or last session) descriptives, box/range plot, per-participant
// values, ANOVA (classical and Welch), pairwise t-tests (Holm), Tukey–Kramer / Games–Howell,
// assumption checks and nonparametric tests with APA lines; learning curves over the training
// sessions (phases of stored kind "training"); an example force trace per group with the
// phase's ST / MPF / SFT lines.
#include <string>
#include <vector>

namespace palplab::analysis {

struct ReportOptions {
  int max_trace_points = 1500;  // per force trace (decimated by taking the max |F| per bin)
};

struct ReportFiles {
  std::string markdown, html;
  std::vector<std::string> figures;
  int analyses = 0;  // analysis units written
};

// Reads the store at `db_path` (InputError if it is not a palplab results database) and writes
// the report into `out_dir` (created if needed).
ReportFiles write_report(const std::string& db_path, const std::string& out_dir,
                         const ReportOptions& options = {});

}  // namespace palplab::analysis
