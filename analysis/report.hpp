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
// phase's ST / MPF / SFT lines. Right after the provenance: stills of every prototype the study
// used under the same press, side by side (DIR/stills/*.png, drawn by a StillMaker the caller
// gives: this library has no renderer; without one the report says why there are none).
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace palplab::analysis {

// One prototype under the report's press: what a StillMaker is asked to draw.
struct StillRequest {
  std::string prototype, path, sha256;  // as stored with the results (table prototypes)
  std::string json;                     // the prototype file's text as stored with the results
  std::string region;                   // pressed at its node nearest the region's centroid
  double force = 0.0;                   // N, target device force of the press
  double hold = 0.5;                    // s the press holds the force before the still
  int width = 480, height = 360;        // px
  std::string pressed_png, rest_png;    // files to write: under the press, and at rest
};

struct StillResult {
  std::string skipped;  // non-empty: no still of this prototype, and why
  std::string note;     // drawn, with a remark for the caption (e.g. from the stored JSON)
  int node = -1;        // surface node pressed
  bool force_reached = false;
  double force = 0.0;                // N on the hand at the still
  double visible_deformation = 0.0;  // m, as the prototype draws it
  nlohmann::json camera;             // how the camera was placed (written to stills.json)
};

class StillMaker {
 public:
  virtual ~StillMaker() = default;
  // "" when stills can be drawn on this machine, else why not (e.g. no EGL device).
  virtual std::string unavailable() = 0;
  virtual StillResult make(const StillRequest& request) = 0;
  // One sentence for the report: how every still's camera is placed.
  virtual std::string camera_convention() const = 0;
};

struct ReportOptions {
  int max_trace_points = 1500;  // per force trace (decimated by taking the max |F| per bin)
  // Draws the stills; null: none, and the report gives `no_stills_reason`.
  std::shared_ptr<StillMaker> stills;
  std::string no_stills_reason = "no renderer was given to the report writer";
  int still_width = 480, still_height = 360;  // px
  double still_hold = 0.5;                    // s
};

struct ReportFiles {
  std::string markdown, html;
  std::vector<std::string> figures;
  std::vector<std::string> stills;  // PNG files written (pressed and rest, per prototype)
  std::string stills_listing;       // stills/stills.json when written, else empty
  int still_figures = 0;            // <figure>s of stills in report.html (one per prototype)
  std::string stills_skipped;       // non-empty: why the report has no stills (one line)
  std::vector<std::string> stills_missing;  // "PROTOTYPE: why" of each prototype not drawn
  double stills_seconds = 0.0;              // wall time spent on the stills
  int analyses = 0;                         // analysis units written (one per measure/phase)
  int declared = 0;  // entries of the study's "analyses" merged into them (0: the default ones)
};

// Reads the store at `db_path` (InputError if it is not a palplab results database) and writes
// the report into `out_dir` (created if needed).
ReportFiles write_report(const std::string& db_path, const std::string& out_dir,
                         const ReportOptions& options = {});

}  // namespace palplab::analysis
