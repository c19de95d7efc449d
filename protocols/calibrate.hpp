#pragma once
// Calibration of participant-model parameters to human data (`palplab calibrate`;
// docs/PARTICIPANTS.md "Calibration").
//
// Data: a tidy CSV (participant, group, phase, session, measure, value; `palplab export`
// writes the same shape) reduced to cells (group, phase, session, measure) with n, mean, SD.
// Loss (a simulated-moments distance, χ²-like): over the cells,
//   Σ (m_sim - m_h)² / (s_h²/n_h + s_h²/n_sim) + (s_sim - s_h)² / (s_h²/(2(n_h-1)) +
//   s_h²/(2(n_sim-1)))
//   + 25 · |share of simulated values undefined - share of human values undefined|
// (s_h floored at 1 % of |m_h| and 1e-9, so a constant human cell cannot divide by 0),
// i.e. each simulated mean and SD is compared with the human one in units of its sampling SE
// (human sampling error plus simulation error); undefined measures (feature never found) are
// compared as shares. Common random numbers: every
// evaluation simulates the same plan (same seeds), so the loss changes only through the
// parameters. Optimiser: Nelder–Mead (Lagarias et al. 1998 coefficients) on parameters scaled
// by their starting step, projected into their bounds, restarted from the best point until a
// restart no longer improves or the budget of loss evaluations is spent. Standard errors: from
// the curvature of the loss at the optimum (loss ≈ -2 log L, so Cov ≈ 2 H⁻¹, H by central
// finite differences).
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "protocols/study.hpp"

namespace palplab::protocols {

struct HumanCell {
  std::string group, phase;
  int session = 1;
  std::string measure;
  int n = 0;          // defined values
  int undefined = 0;  // empty / NA values (e.g. the feature was never found)
  double mean = 0.0, sd = 0.0;
  std::string file;  // the CSV and the line of the cell's first row, for messages
  int line = 0;
  int measure_column = 0;  // the column of that row's measure field (0: unknown)
  int group_column = 0, phase_column = 0, session_column = 0;  // and of its other key fields
  std::vector<int> value_lines, undefined_lines;  // the lines of its values / undefined rows
  // Who gave what: the participants of its defined values (parallel to `values`, in file order)
  // and of its undefined ones (`palplab power --human` reanalyses and resamples them).
  std::vector<std::string> participants, undefined_participants;
  std::vector<double> values;
};

// Reads a tidy CSV (columns participant, group, phase, session, measure, value) into cells
// (empty or NA values, i.e. undefined measures, are left out);
// InputError with the line for missing columns, a session that is not a positive integer,
// non-numbers, a value outside its measure's range (feature_identified 0 or 1, accuracy 0–100 %,
// counts whole numbers >= 0, forces 0-1e6 N, times 0-86400 s, distances >= 0), a (participant,
// group, phase, session, measure) given twice or a participant given in two groups (groups are
// between-participant). Cells with fewer than 2 values are kept: calibrate() refuses them among
// the cells it fits. Measures are checked against the study by calibrate().
std::vector<HumanCell> read_human_cells(const std::string& csv_path);

// The SD the loss divides by for a human cell: its SD, but at least 1 % of |mean| (and 1e-9), so
// that a cell of equal values (SD 0) does not make the loss infinite; such a cell still weighs
// far more than the others (`palplab calibrate` warns about it: sd_floor_warnings).
double loss_sd(const HumanCell& c);
// One line per cell of the `fitted` measures with at least 2 values whose SD is below that floor
// (cells of other measures are not in the loss).
std::vector<std::string> sd_floor_warnings(const std::vector<HumanCell>& cells,
                                           const std::vector<std::string>& fitted);

struct CellFit {
  HumanCell human;
  int n_sim = 0, undefined = 0;
  double mean = 0.0, sd = 0.0;  // simulated
  double z_mean = 0.0, z_sd = 0.0;
};

// Why a cell's simulated moments (and so its z) are undefined: "" when n_sim >= 2, else e.g.
// "no simulated participant produced this measure: all 3 undefined".
std::string not_compared_reason(const CellFit& f);

// The measures a session of `study` writes (its declared measures and every measure its task's
// sessions compute, e.g. palpations and sft_reached beside the palpation measures): the
// measures a tidy CSV of this study (`palplab export`) can hold.
std::vector<std::string> produced_measures(const Study& study);

// InputError at `c`'s first row (its measure field) when the study never produces its measure
// (produced_measures; `cells`: all of them, to count that measure's rows).
void check_human_measure(const Study& study, const std::vector<HumanCell>& cells,
                         const HumanCell& c);
// InputError at `c`'s first row (the field at fault) when it is a cell the study does not
// simulate: a group or phase the study does not have, a session beyond the phase's sessions.
void check_human_cell(const Study& study, const HumanCell& c);

// A cell's z-scores from its simulated mean, SD and count and its human cell (NaN when fewer
// than 2 simulated values): moment_loss's, and the journal's check of a stored line.
void set_cell_z(CellFit& f);
// One cell's terms of the loss, added to `loss` in the order moment_loss adds them (so that a
// loss recomputed from its cells — the journal's check — is the same to the bit).
void add_cell_loss(double& loss, const CellFit& f);

// Simulates `study` and compares it with `cells`; returns the loss (see above).
double moment_loss(const Study& study, const std::vector<HumanCell>& cells, int jobs,
                   std::vector<CellFit>* fit = nullptr);

// Minimises f over x in [lo, hi] (box) with Nelder–Mead and restarts; `step` is the initial
// simplex size per coordinate. Stops after `budget` evaluations of f.
struct NelderMeadResult {
  std::vector<double> x;
  double f = 0.0;
  int evaluations = 0, restarts = 0;
  // The search ended by itself (the simplex shrank or its values agreed, and a restart found
  // nothing better); false when `budget` ran out first.
  bool converged = false;
};
NelderMeadResult nelder_mead(const std::function<double(const std::vector<double>&)>& f,
                             std::vector<double> x0, const std::vector<double>& step,
                             const std::vector<double>& lo, const std::vector<double>& hi,
                             int budget);

// Standard errors from the loss's average curvature over a set of simulated points: the
// least-squares quadratic q(x) = c + gᵀu + ½ uᵀHu, u = (x − centre) / scale per coordinate, through
// every (x[k], f[k]); Cov = 2 H⁻¹ (loss ≈ −2 log L) over the coordinates with free[i] true (the
// others held, as the curvature stencil holds a parameter on its bound). NaN for every coordinate
// when the points do not determine the quadratic with a residual to spare (fewer than its
// 1 + d + d(d+1)/2 coefficients plus one, or collinear) and where the free block of H is not
// positive definite. Beside the stencil's curvature at the fit (CalibrationResult::se), which a
// loss that is rough at the stencil's scale makes far too small, this is the curvature of the
// whole region the search covered.
// The points calibrate() gives quadratic_se(): those with a loss within this of the fit's, the
// region within 3 SEs of a quadratic loss's minimum (loss ≈ −2 log L: Δloss = k² at k SEs).
inline constexpr double kQuadraticRegion = 9.0;
std::vector<double> quadratic_se(const std::vector<std::vector<double>>& x,
                                 const std::vector<double>& f, const std::vector<double>& centre,
                                 const std::vector<double>& scale, const std::vector<bool>& free);

// A fit's own bounds for one parameter (`--bounds NAME=LO:HI`), narrower than or equal to the
// parameter table's (protocols/participants/params.cpp).
struct ParamBound {
  std::string name;
  double lo = 0.0, hi = 0.0;
};
// Parses "NAME=LO:HI" (LO < HI, both finite numbers); InputError at "--bounds" otherwise. Whether
// NAME is fitted and LO:HI lies within its table's bounds is checked by calibrate().
ParamBound parse_bound(const std::string& text);

struct CalibrateOptions {
  std::vector<std::string> keys;  // trainee parameter names to fit
  // Bounds of this fit for some of `keys` (the others keep their table's bounds). Each must lie
  // within its table's bounds and hold the start value; InputError at "--bounds" otherwise.
  std::vector<ParamBound> bounds;
  int budget = 200;  // loss evaluations for the optimiser (the SEs need 2p² more)
  int jobs = 1;
  int sim_n = 0;  // simulated participants per group; 0 = the study's group sizes
  // Measures to fit (cells of other measures in the CSV are ignored); empty = the study's
  // declared "measures".
  std::vector<std::string> measures;
  // false: skip the curvature stencil (2p² extra simulations) when time is short; the
  // SEs are then reported as not computed.
  bool standard_errors = true;
  // Called after every simulation (a point simulated once is not simulated again); `best` is the
  // optimiser's best loss so far, `stencil` true for the points of the standard errors' stencil
  // (simulated after the fit; they do not change `best`, see CalibrationResult::stencil_lower).
  // `from_journal`: the evaluation was read from `journal`, not simulated.
  std::function<void(int evaluation, double loss, double best, const std::vector<double>& x,
                     bool stencil, bool from_journal)>
      progress;
  // Where every simulated evaluation is appended as it finishes (protocols/calibrate_journal.hpp;
  // empty: nowhere). The evaluations of the same set-up found there are taken instead of
  // simulated again, so the same command resumes an interrupted fit and ends with the result of
  // an uninterrupted one; the start is always simulated and must equal its stored evaluation
  // (InputError otherwise: a palplab that simulates differently wrote the file).
  std::string journal;
  // Said once, before the first simulation: where the evaluations go and how many of this fit's
  // the journal already holds (a resumed fit first simulates its start again, which takes as
  // long as any evaluation, before the stored ones are replayed).
  std::function<void(const std::string& message)> notice;
  // Called for every line of sd_floor_warnings() of the fitted measures, once the inputs have
  // been checked (not before an input error that refuses the fit), before the first simulation.
  std::function<void(const std::string& message)> warning;
};

struct CalibrationResult {
  std::vector<std::string> keys;
  std::vector<double> start, fitted, se;  // se NaN when the curvature is not positive definite
  std::vector<double> lo, hi;             // the bounds searched (--bounds, else the table's)
  // false with CalibrateOptions::standard_errors off, or when only the start was simulated
  // (--budget 1: nothing fitted, so no curvature of a fit to measure).
  bool se_computed = true;
  bool converged = false;  // NelderMeadResult::converged: false = stopped by --budget
  double loss_before = 0.0, loss_after = 0.0;
  int evaluations = 0, restarts = 0;
  std::vector<CellFit> fit_before, fit_after;
  nlohmann::json parameters;  // the study's parameters with the fitted values applied
  // Measures of the study found in the human data but not fitted (their cells are ignored;
  // --measures selects), in order of first appearance.
  std::vector<std::string> not_fitted;
  // No point tried lowered the start's loss beyond rounding (relatively 1e-9): the start was kept
  // (the optimiser may have ended there or at a point with the same loss).
  bool kept_start = false;
  // With kept_start: every point tried had the start's loss up to rounding (the parameters have
  // no effect on the fitted cells), as opposed to a start that is a minimum of the points tried.
  bool loss_flat = false;
  // Distinct parameter points simulated by the optimiser (the start included; the SE stencil's
  // points not): 1 when --budget 1 only evaluated the start, so nothing was fitted.
  int points_tried = 0;
  int budget = 0;  // the optimiser's budget (CalibrateOptions::budget)
  // Evaluations taken from CalibrateOptions::journal instead of simulated (counted in
  // `evaluations` as well: the fit is the same as an uninterrupted one's).
  int replayed = 0;
  // Lines of this fit in the journal written by another palplab build (used: the start's check
  // passed; said in the text).
  int journal_other_build = 0;
  // The lowest loss among the SE stencil's points when it is below loss_after beyond rounding
  // (empty otherwise): the optimiser's end point is then no minimum at the stencil's scale. The
  // fit is not moved there (its SEs are the end point's curvature); the report says where it is,
  // so a refit can start from it.
  std::vector<double> stencil_lower;
  double stencil_lower_loss = 0.0;
  // quadratic_se() over the points simulated (the optimiser's and the stencil's) whose loss is
  // within kQuadraticRegion of loss_after (NaN when too few): the loss's curvature over the
  // region the SEs are about, reported beside `se`; quadratic_points of them.
  std::vector<double> se_quadratic;
  int quadratic_points = 0;
};

// Before any simulation, InputError (with the CSV line) for a cell of a measure the study does
// not produce (produced_measures(); a typo would otherwise be ignored silently) and for a fitted
// cell (one of the measures to fit) whose group, phase or session the study lacks or that has
// fewer than 2 values.
CalibrationResult calibrate(const Study& study, const std::vector<HumanCell>& cells,
                            const CalibrateOptions& opt);

// Writes the fitted values as the new defaults into the member initialisers of
// `struct TraineeParams` in `params_hpp` (protocols/participants/params.hpp), so the shipped
// defaults are exactly this command's output after a rebuild. InputError when the file or a
// member is not found.
void write_defaults(const CalibrationResult& r, const std::string& params_hpp);
// Before a fit: InputError unless write_defaults could set every one of `keys` in params_hpp.
void check_defaults_file(const std::vector<std::string>& keys, const std::string& params_hpp);

nlohmann::json to_json(const CalibrationResult& r);
std::string to_text(const CalibrationResult& r);

}  // namespace palplab::protocols
