#include "protocols/calibrate.hpp"

#include "results/measure_kind.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <regex>
#include <sstream>
#include <tuple>

#include "analysis/csv.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/nan.hpp"
#include "common/write_file.hpp"
#include "protocols/calibrate_journal.hpp"
#include "protocols/measures.hpp"
#include "protocols/participants/params.hpp"
#include "protocols/power.hpp"

namespace palplab::protocols {

namespace {

void mean_sd(const std::vector<double>& x, double& m, double& sd) {
  // Equal values have exactly their value as mean and SD 0 (ten forces of 2.9 N summed to a mean
  // 4e-16 off, whose "SD 4.681e-16" a warning printed; review 2026-12-07).
  if (!x.empty() && std::all_of(x.begin(), x.end(), [&](double v) { return v == x.front(); })) {
    m = x.front(), sd = 0.0;
    return;
  }
  m = std::accumulate(x.begin(), x.end(), 0.0) / std::max<std::size_t>(1, x.size());
  double ss = 0;
  for (double v : x) ss += (v - m) * (v - m);
  sd = x.size() > 1 ? std::sqrt(ss / (x.size() - 1)) : 0.0;
}

}  // namespace

ParamBound parse_bound(const std::string& text) {
  auto fail = [&](const std::string& why) {
    return InputError(SourceLocation{"--bounds"},
                      "\"" + text + "\": " + why +
                          "; expected NAME=LO:HI with finite numbers LO < HI, e.g. "
                          "weber_fraction=0.04:0.10");
  };
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos) throw fail("no '='");
  ParamBound b;
  b.name = text.substr(0, eq);
  if (b.name.empty()) throw fail("no parameter name before '='");
  const std::string range = text.substr(eq + 1);
  const std::size_t colon = range.find(':');
  if (colon == std::string::npos) throw fail("no ':' between LO and HI");
  auto number = [&](const std::string& text_in, const char* which) {
    // Decimal notation as written in a shell: surrounding blanks and one leading '+' allowed.
    std::string t = text_in;
    t.erase(0, t.find_first_not_of(" \t"));
    t.erase(t.find_last_not_of(" \t") + 1);
    const std::string digits = !t.empty() && t[0] == '+' ? t.substr(1) : t;
    double v = 0.0;
    const char* end = digits.data() + digits.size();
    const auto [ptr, ec] = std::from_chars(digits.data(), end, v);
    if (ec == std::errc::result_out_of_range && ptr == end) {
      const double approx = std::strtod(digits.c_str(), nullptr);  // ±HUGE_VAL or a tiny value
      throw fail(std::string(which) + " \"" + text_in + "\" is " +
                 (std::isinf(approx) ? "too large" : "too small (below the smallest double)") +
                 " in magnitude");
    }
    if (digits.empty() || digits[0] == '+' || ec != std::errc() || ptr != end)
      throw fail(std::string(which) + " \"" + text_in + "\" is not a number");
    if (!std::isfinite(v)) throw fail(std::string(which) + " is not finite");
    return v + 0.0;  // -0 is 0
  };
  b.lo = number(range.substr(0, colon), "LO");
  b.hi = number(range.substr(colon + 1), "HI");
  if (!(b.lo < b.hi)) throw fail("LO is not below HI");
  return b;
}

namespace {

// The values a measure can take (protocols/measures.hpp); "" when any number will do.
std::string out_of_range(const std::string& measure, double v) {
  if (measure == "feature_identified") return v == 0 || v == 1 ? "" : "0 or 1";
  if (measure == "accuracy") return v >= 0 && v <= 100 ? "" : "a percentage from 0 to 100";
  if (results::is_count_measure(measure))
    return v >= 0 && v == std::floor(v) ? "" : "a count, a whole number >= 0";
  // A force or time beyond what any study can produce is a typo or a unit error (1e100 was
  // taken, and its SD then took the cell out of the loss).
  if (measure == "palpation_force")
    return v >= 0 && v <= kMaxTaskForce ? "" : "a force from 0 to 1e6 N";
  if (measure == "exploration_time" || measure == "procedure_time")
    return v >= 0 && v <= kMaxSessionSeconds ? ""
                                             : "a time from 0 to 86400 s (a session's longest)";
  if (measure == "tip_to_target_mm") return v >= 0 ? "" : "a number >= 0 (mm)";
  return "";
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

// "line 4" / "lines 4, 9"
std::string lines_text(const std::vector<int>& lines) {
  std::string s = lines.size() == 1 ? "line " : "lines ";
  for (std::size_t i = 0; i < lines.size(); ++i) s += (i ? ", " : "") + std::to_string(lines[i]);
  return s;
}

// Column 'session' of row r: the 1-based session number within the phase, a positive integer
// written as digits (as `palplab export` writes it); 1.5, 0, -1, 2e0 or text are errors at the
// field.
int session_number(const analysis::CsvTable& t, std::size_t r, int col) {
  const std::string& field = t.rows[r][col];
  const std::size_t b = field.find_first_not_of(" \t"), e = field.find_last_not_of(" \t");
  const std::string v = b == std::string::npos ? std::string() : field.substr(b, e - b + 1);
  const bool digits =
      !v.empty() && v.size() <= 7 && v.find_first_not_of("0123456789") == std::string::npos;
  const long n = digits ? std::stol(v) : 0;
  if (n >= 1 && n <= 1000000) return static_cast<int>(n);
  const std::size_t f = r * t.header.size() + col;
  const bool located = f < t.field_line.size();
  throw InputError(
      SourceLocation{t.file, located ? t.field_line[f] : t.line[r],
                     located ? t.field_column[f] : 0},
      "column 'session': expected a positive integer (the session number within its phase: 1, "
      "2, ...), got " +
          (v.empty() ? std::string("an empty field") : "'" + field + "'"));
}

}  // namespace

double loss_sd(const HumanCell& c) {
  return std::max(c.sd, std::max(0.01 * std::abs(c.mean), 1e-9));
}

std::vector<std::string> sd_floor_warnings(const std::vector<HumanCell>& cells,
                                           const std::vector<std::string>& fitted) {
  std::vector<std::string> out;
  for (const auto& c : cells) {
    if (c.n < 2 || c.sd >= loss_sd(c)) continue;
    if (std::find(fitted.begin(), fitted.end(), c.measure) == fitted.end()) continue;
    char b[96];
    std::snprintf(b, sizeof b, "SD %.4g is below 1 %% of the mean %.4g; the loss uses %.4g", c.sd,
                  c.mean, loss_sd(c));
    out.push_back(c.file + ":" + std::to_string(c.line) + ": group " + c.group + ", phase " +
                  c.phase + ", session " + std::to_string(c.session) + ", measure " + c.measure +
                  ": " + b +
                  " (the cell's values are nearly equal: it weighs far more than the "
                  "others in the fit)");
  }
  return out;
}

std::vector<HumanCell> read_human_cells(const std::string& csv_path) {
  const analysis::CsvTable t = analysis::read_csv(csv_path);
  int col[6];
  const char* names[6] = {"group", "phase", "session", "measure", "value", "participant"};
  for (int i = 0; i < 6; ++i) {
    col[i] = analysis::column_index(t, names[i]);
    if (col[i] < 0)
      throw InputError(SourceLocation{csv_path, 1, 1},
                       std::string("missing column \"") + names[i] +
                           "\" (expected participant,group,phase,session,measure,value)");
  }
  using Key = std::tuple<std::string, std::string, int, std::string>;
  std::map<Key, std::vector<double>> values;
  std::map<Key, int> first_line;
  std::vector<Key> order;
  std::map<Key, int> undefined;
  std::map<Key, std::vector<int>> value_lines, undefined_lines;
  std::map<Key, std::vector<std::string>> who, who_undefined;
  std::map<Key, int> measure_column, group_column, phase_column, session_column;
  // (participant, cell) -> the line it was first given on: one value per participant and cell.
  std::map<std::pair<std::string, Key>, int> seen;
  // participant -> (group, line of its first row): groups are between-participant, so a
  // participant in two groups (a typo in either column, or ids reused across groups) would be
  // counted in both.
  std::map<std::string, std::pair<std::string, int>> group_of;
  // Where field `c` of row `r` starts (the row's start for tables without field positions).
  auto at = [&](std::size_t r, int c) {
    const std::size_t f = r * t.header.size() + c;
    return f < t.field_line.size() ? SourceLocation{csv_path, t.field_line[f], t.field_column[f]}
                                   : SourceLocation{csv_path, t.line[r], 0};
  };
  // The optional unit column (as `palplab export` writes it): values are compared in palplab's
  // units, so a unit that differs from the measure's is an error, never silently converted.
  int unit_col = -1;
  // Its header in any case, "unit" or "units" ("Unit" was ignored, and values in another unit
  // passed unchecked).
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    std::string h = t.header[c];
    for (char& ch : h) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (h == "unit" || h == "units") {
      if (unit_col >= 0)
        throw InputError(SourceLocation{csv_path, 1, 1},
                         "two unit columns (\"" + t.header[unit_col] + "\" and \"" + t.header[c] +
                             "\"); expected at most one");
      unit_col = static_cast<int>(c);
    }
  }
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    // Ids and names never hold control characters, C0, DEL or C1 (a NUL in a participant id
    // passed here, where the study file refuses it; review 2026-12-07).
    for (const int c : {col[0], col[1], col[3], col[5]}) {
      const std::string& f = t.rows[r][c];
      for (std::size_t i = 0, n = 1; i < f.size(); i += n) {
        const char32_t cp = utf8_code_point(f, i, &n);
        if ((cp < 0x20 && cp != '\t') || (cp >= 0x7f && cp <= 0x9f)) {
          char u[16];
          std::snprintf(u, sizeof u, "U+%04X", static_cast<unsigned>(cp));
          throw InputError(at(r, c), "column '" + t.header[c] + "': a control character (" + u +
                                         ") in '" + shown_text(f) +
                                         "' (ids and names are printable text)");
        }
      }
    }
    const int s = session_number(t, r, col[2]);
    auto key = std::make_tuple(t.rows[r][col[0]], t.rows[r][col[1]], s, t.rows[r][col[3]]);
    // Ids are compared without surrounding blanks ("P1 " is P1: a participant given twice or in
    // two groups must not pass as another person).
    const std::string& raw_id = t.rows[r][col[5]];
    const std::size_t id_b = raw_id.find_first_not_of(" \t"), id_e = raw_id.find_last_not_of(" \t");
    const std::string participant =
        id_b == std::string::npos ? std::string() : raw_id.substr(id_b, id_e - id_b + 1);
    if (participant.empty())
      throw InputError(at(r, col[5]),
                       "column 'participant': expected the participant's id, got an empty field");
    if (unit_col >= 0) {
      const std::string& unit = t.rows[r][unit_col];
      const std::string expected = measure_unit(std::get<3>(key));
      const std::size_t b = unit.find_first_not_of(" \t"), e = unit.find_last_not_of(" \t");
      const std::string u = b == std::string::npos ? "" : unit.substr(b, e - b + 1);
      if (!u.empty() && u != "NA" && !expected.empty() && u != expected)
        throw InputError(at(r, unit_col), "column 'unit': " + std::get<3>(key) + " is in " +
                                              expected + ", got '" + unit +
                                              "' (palplab compares values in its own units: "
                                              "convert the values and write " +
                                              expected + ")");
    }
    if (auto [it, fresh] =
            group_of.emplace(participant, std::make_pair(std::get<0>(key), t.line[r]));
        !fresh && it->second.first != std::get<0>(key))
      throw InputError(at(r, col[0]), "participant \"" + participant + "\" is in group \"" +
                                          std::get<0>(key) + "\" here but in group \"" +
                                          it->second.first + "\" on line " +
                                          std::to_string(it->second.second) +
                                          "; expected each participant in one group (groups are "
                                          "between-participant: ids must be unique across groups)");
    if (auto [it, fresh] = seen.emplace(std::make_pair(participant, key), t.line[r]); !fresh)
      throw InputError(SourceLocation{csv_path, t.line[r], 1},
                       "participant " + participant + ", group " + std::get<0>(key) + ", phase " +
                           std::get<1>(key) + ", session " + std::to_string(std::get<2>(key)) +
                           ", measure " + std::get<3>(key) + " is given twice (lines " +
                           std::to_string(it->second) + " and " + std::to_string(t.line[r]) +
                           "); expected one value per participant, session and measure");
    // An undefined measure (empty or NA, as `palplab export` and R write it) is no value.
    const std::string& field = t.rows[r][col[4]];
    if (!values.count(key))
      order.push_back(key), first_line[key] = t.line[r], measure_column[key] = at(r, col[3]).column,
                            group_column[key] = at(r, col[0]).column,
                            phase_column[key] = at(r, col[1]).column,
                            session_column[key] = at(r, col[2]).column;
    if (field.find_first_not_of(" \t") == std::string::npos || field == "NA") {
      ++undefined[key];
      values[key];
      undefined_lines[key].push_back(t.line[r]);
      who_undefined[key].push_back(participant);
      continue;
    }
    const double v = analysis::parse_number(t, static_cast<int>(r), col[4]);
    if (const std::string expected = out_of_range(std::get<3>(key), v); !expected.empty())
      throw InputError(at(r, col[4]), "column 'value': " + std::get<3>(key) + " must be " +
                                          expected + ", got " + field);
    values[key].push_back(v);
    value_lines[key].push_back(t.line[r]);
    who[key].push_back(participant);
  }
  if (order.empty()) throw InputError("no data rows", csv_path);
  std::vector<HumanCell> cells;
  for (const auto& key : order) {
    const auto& v = values[key];
    HumanCell c{std::get<0>(key), std::get<1>(key),           std::get<2>(key),
                std::get<3>(key), static_cast<int>(v.size()), undefined[key]};
    c.file = csv_path;
    c.line = first_line[key];
    c.measure_column = measure_column[key];
    c.group_column = group_column[key];
    c.phase_column = phase_column[key];
    c.session_column = session_column[key];
    c.value_lines = value_lines[key];
    c.undefined_lines = undefined_lines[key];
    c.participants = who[key];
    c.undefined_participants = who_undefined[key];
    c.values = v;
    mean_sd(v, c.mean, c.sd);  // only cells with n >= 2 are fitted (checked by calibrate)
    cells.push_back(c);
  }
  return cells;
}

std::string not_compared_reason(const CellFit& f) {
  if (f.n_sim >= 2) return "";
  const std::string total = std::to_string(f.n_sim + f.undefined);
  return f.n_sim == 0
             ? "no simulated participant produced this measure: all " + total + " undefined"
             : "only 1 of " + total +
                   " simulated participants produced this measure: an SD needs 2";
}

std::vector<std::string> produced_measures(const Study& study) {
  std::vector<std::string> out = study.measures;
  auto add = [&](const std::string& m) {
    if (std::find(out.begin(), out.end(), m) == out.end()) out.push_back(m);
  };
  for (const auto& m : default_measures(study.task.kind)) add(m);
  // The names every session of the task writes, from the functions that compute them (a
  // session without samples or events: all undefined or 0, but every name is there).
  const results::SampleSeries no_samples;
  const std::vector<results::EventRecord> no_events;
  const std::vector<int> no_regions;
  MeasureInputs in;
  in.samples = &no_samples;
  in.events = &no_events;
  in.vertex_region = &no_regions;
  for (const auto& m : study.task.kind == "needle_insertion" ? compute_needle_measures(no_events)
                                                             : compute_measures(in))
    add(m.name);
  return out;
}

double moment_loss(const Study& study, const std::vector<HumanCell>& cells, int jobs,
                   std::vector<CellFit>* fit) {
  const std::vector<SimValue> sim = simulate_study(study, jobs);
  double loss = 0.0;
  if (fit) fit->clear();
  for (const auto& c : cells) {
    CellFit f;
    f.human = c;
    std::vector<double> x;
    for (const auto& v : sim)
      if (v.group == c.group && v.phase == c.phase && v.session == c.session &&
          v.measure == c.measure) {
        if (v.value)
          x.push_back(*v.value);
        else
          ++f.undefined;
      }
    const int total = static_cast<int>(x.size()) + f.undefined;
    if (total == 0)
      throw InputError(SourceLocation{c.file, c.line},
                       "the human data have a cell the study does not simulate: group " + c.group +
                           ", phase " + c.phase + ", session " + std::to_string(c.session) +
                           ", measure " + c.measure);
    f.n_sim = static_cast<int>(x.size());
    if (x.size() < 2)
      f.mean = f.sd = kNaN;
    else
      mean_sd(x, f.mean, f.sd);
    set_cell_z(f);
    add_cell_loss(loss, f);
    if (fit) fit->push_back(f);
  }
  return loss;
}

void set_cell_z(CellFit& f) {
  if (f.n_sim < 2) {
    f.z_mean = f.z_sd = kNaN;
    return;
  }
  const HumanCell& c = f.human;
  const double s2 = std::pow(loss_sd(c), 2);
  const double var_m = s2 / c.n + s2 / f.n_sim;
  const double var_s = s2 / (2.0 * (c.n - 1)) + s2 / (2.0 * (f.n_sim - 1));
  f.z_mean = (f.mean - c.mean) / std::sqrt(var_m);
  f.z_sd = (f.sd - c.sd) / std::sqrt(var_s);
}

void add_cell_loss(double& loss, const CellFit& f) {
  if (f.n_sim < 2)
    loss += 1e3;  // nothing to compare: far worse than any fit
  else
    loss += f.z_mean * f.z_mean + f.z_sd * f.z_sd;
  const HumanCell& c = f.human;
  const int total = f.n_sim + f.undefined;
  const double u_h = static_cast<double>(c.undefined) / (c.n + c.undefined);
  loss += 25.0 * std::abs(static_cast<double>(f.undefined) / total - u_h);
}

NelderMeadResult nelder_mead(const std::function<double(const std::vector<double>&)>& f,
                             std::vector<double> x0, const std::vector<double>& step,
                             const std::vector<double>& lo, const std::vector<double>& hi,
                             int budget) {
  const std::size_t d = x0.size();
  NelderMeadResult res;
  // Work in z = (x - x0) / step, project x into [lo, hi].
  const std::vector<double> origin = x0;
  auto to_x = [&](const std::vector<double>& z) {
    std::vector<double> x(d);
    for (std::size_t i = 0; i < d; ++i) x[i] = std::clamp(origin[i] + z[i] * step[i], lo[i], hi[i]);
    return x;
  };
  auto eval = [&](const std::vector<double>& z) {
    ++res.evaluations;
    return f(to_x(z));
  };
  std::vector<double> best_z(d, 0.0);
  double best_f = eval(best_z);
  const double alpha = 1.0, gamma = 2.0, rho = 0.5, sigma = 0.5;
  for (int restart = 0; res.evaluations < budget; ++restart) {
    // Simplex of d + 1 points around the best point, unit size in z.
    std::vector<std::vector<double>> pts(d + 1, best_z);
    std::vector<double> fv(d + 1, best_f);
    for (std::size_t i = 0; i < d && res.evaluations < budget; ++i) {
      // Towards the other side where a step up would be cut back onto the point by its upper
      // bound: a simplex point equal to its neighbour has its loss, and the search would end as
      // converged where it started (a start on the upper bound never moved before).
      const double at = to_x(pts[i + 1])[i];
      pts[i + 1][i] += 1.0;
      if (to_x(pts[i + 1])[i] == at) pts[i + 1][i] -= 2.0;
      fv[i + 1] = eval(pts[i + 1]);
    }
    const double start_f = best_f;
    while (res.evaluations < budget) {
      std::vector<std::size_t> idx(d + 1);
      std::iota(idx.begin(), idx.end(), 0);
      std::sort(idx.begin(), idx.end(), [&](auto a, auto b) { return fv[a] < fv[b]; });
      const std::size_t b = idx[0], w = idx[d], sw = idx[d - 1 < d ? d - 1 : 0];
      // Converged: the simplex is tiny or its values agree.
      double size = 0;
      for (std::size_t i = 0; i <= d; ++i)
        for (std::size_t k = 0; k < d; ++k) size = std::max(size, std::abs(pts[i][k] - pts[b][k]));
      if (size < 1e-3 || std::abs(fv[w] - fv[b]) <= 1e-8 * (1 + std::abs(fv[b]))) break;
      std::vector<double> c(d, 0.0);
      for (std::size_t i = 0; i <= d; ++i)
        if (i != w)
          for (std::size_t k = 0; k < d; ++k) c[k] += pts[i][k] / d;
      auto along = [&](double t) {
        std::vector<double> z(d);
        for (std::size_t k = 0; k < d; ++k) z[k] = c[k] + t * (pts[w][k] - c[k]);
        return z;
      };
      auto xr = along(-alpha);
      const double fr = eval(xr);
      if (fr < fv[b]) {
        auto xe = along(-gamma);
        const double fe = res.evaluations < budget ? eval(xe) : fr + 1;
        if (fe < fr)
          pts[w] = xe, fv[w] = fe;
        else
          pts[w] = xr, fv[w] = fr;
      } else if (fr < fv[sw]) {
        pts[w] = xr, fv[w] = fr;
      } else {
        const bool outside = fr < fv[w];
        auto xc = along(outside ? -rho : rho);
        if (res.evaluations >= budget) {         // the reflection took the last evaluation: kept
          if (outside) pts[w] = xr, fv[w] = fr;  // when it beats the worst point
          break;
        }
        const double fc = eval(xc);
        if (fc < (outside ? fr : fv[w])) {
          pts[w] = xc, fv[w] = fc;
        } else {
          for (std::size_t i = 0; i <= d && res.evaluations < budget; ++i) {
            if (i == b) continue;
            for (std::size_t k = 0; k < d; ++k)
              pts[i][k] = pts[b][k] + sigma * (pts[i][k] - pts[b][k]);
            fv[i] = eval(pts[i]);
          }
        }
      }
    }
    for (std::size_t i = 0; i <= d; ++i)
      if (fv[i] < best_f) best_f = fv[i], best_z = pts[i];
    res.restarts = restart;
    // A restart that found nothing better ends the search.
    if (restart > 0 && best_f >= start_f - 1e-9 * (1 + std::abs(start_f))) {
      res.converged = true;
      break;
    }
  }
  res.x = to_x(best_z);
  res.f = best_f;
  return res;
}

namespace {

// sqrt(diag(2 H⁻¹)) (loss ≈ −2 log L, Cov ≈ 2 H⁻¹), or NaN for each when H is not positive
// definite: what both standard errors make of their curvature matrix.
std::vector<double> se_from_curvature(const Eigen::MatrixXd& H) {
  std::vector<double> se(H.rows(), kNaN);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(H);
  if (es.info() != Eigen::Success || !(es.eigenvalues().minCoeff() > 0)) return se;
  const Eigen::MatrixXd cov = 2.0 * H.inverse();
  for (Eigen::Index a = 0; a < H.rows(); ++a) se[a] = std::sqrt(cov(a, a));
  return se;
}

// Standard errors from the curvature of the loss at r.fitted (loss ≈ -2 log L, Cov ≈ 2 H⁻¹);
// r.se stays NaN where H is not positive definite. A parameter on one of its bounds has no SE
// (the optimum there is the bound's, and a stencil cut at the bound would measure a slope, not a
// curvature): the others' come from the curvature with it held at its bound.
void standard_errors(CalibrationResult& r, const std::vector<double>& step,
                     const std::vector<double>& lo, const std::vector<double>& hi,
                     const std::function<double(const std::vector<double>&)>& loss) {
  // Curvature at the optimum by central differences, h = 20 % of the starting step (5 % of the
  // starting value): wide enough to average over the small steps that common random numbers
  // leave in the loss (a discrete event, such as a press more or less, moves it by a step).
  std::vector<std::size_t> free;
  for (std::size_t i = 0; i < r.fitted.size(); ++i)
    if (r.fitted[i] > lo[i] && r.fitted[i] < hi[i]) free.push_back(i);
  const std::size_t d = free.size();
  if (d == 0) return;
  Eigen::MatrixXd H(d, d);
  std::vector<double> h(d);
  for (std::size_t a = 0; a < d; ++a) {
    const std::size_t i = free[a];
    // Keep the stencil inside the bounds.
    h[a] = std::min(0.2 * step[i], std::min(r.fitted[i] - lo[i], hi[i] - r.fitted[i]));
  }
  auto at = [&](std::size_t a, double da, std::size_t b, double db) {
    std::vector<double> x = r.fitted;
    x[free[a]] += da;
    x[free[b]] += db;
    for (std::size_t k = 0; k < x.size(); ++k) x[k] = std::clamp(x[k], lo[k], hi[k]);
    return loss(x);
  };
  const double f0 = r.loss_after;
  for (std::size_t a = 0; a < d; ++a) {
    H(a, a) = (at(a, h[a], a, 0) - 2 * f0 + at(a, -h[a], a, 0)) / (h[a] * h[a]);
    for (std::size_t b = 0; b < a; ++b) {
      const double v = (at(a, h[a], b, h[b]) - at(a, h[a], b, -h[b]) - at(a, -h[a], b, h[b]) +
                        at(a, -h[a], b, -h[b])) /
                       (4 * h[a] * h[b]);
      H(a, b) = H(b, a) = v;
    }
  }
  const std::vector<double> se = se_from_curvature(H);
  for (std::size_t a = 0; a < d; ++a) r.se[free[a]] = se[a];
}

}  // namespace

std::vector<double> quadratic_se(const std::vector<std::vector<double>>& x,
                                 const std::vector<double>& f, const std::vector<double>& centre,
                                 const std::vector<double>& scale, const std::vector<bool>& free) {
  const std::size_t d = centre.size();
  std::vector<double> se(d, kNaN);
  const std::size_t terms = 1 + d + d * (d + 1) / 2;
  if (x.size() != f.size() || x.size() < terms + 1) return se;
  // Columns: 1, u_i, then ½u_i² (diagonal) and u_i·u_j (i < j), so the coefficients are H's.
  Eigen::MatrixXd A(x.size(), terms);
  Eigen::VectorXd b(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (x[k].size() != d || !std::isfinite(f[k])) return se;
    std::vector<double> u(d);
    for (std::size_t i = 0; i < d; ++i) u[i] = (x[k][i] - centre[i]) / scale[i];
    std::size_t c = 0;
    A(k, c++) = 1.0;
    for (std::size_t i = 0; i < d; ++i) A(k, c++) = u[i];
    for (std::size_t i = 0; i < d; ++i)
      for (std::size_t j = i; j < d; ++j) A(k, c++) = i == j ? 0.5 * u[i] * u[i] : u[i] * u[j];
    b(k) = f[k];
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < static_cast<Eigen::Index>(terms)) return se;
  const Eigen::VectorXd coef = qr.solve(b);
  std::vector<std::size_t> fr;
  for (std::size_t i = 0; i < d; ++i)
    if (free[i]) fr.push_back(i);
  if (fr.empty()) return se;
  Eigen::MatrixXd H_all(d, d);
  std::size_t c = 1 + d;
  for (std::size_t i = 0; i < d; ++i)
    for (std::size_t j = i; j < d; ++j) H_all(i, j) = H_all(j, i) = coef(c++);
  Eigen::MatrixXd H(fr.size(), fr.size());
  for (std::size_t a = 0; a < fr.size(); ++a)
    for (std::size_t bb = 0; bb < fr.size(); ++bb) H(a, bb) = H_all(fr[a], fr[bb]);
  const std::vector<double> se_u = se_from_curvature(H);  // in u units: back by the scale
  for (std::size_t a = 0; a < fr.size(); ++a) se[fr[a]] = se_u[a] * scale[fr[a]];
  return se;
}

void check_human_measure(const Study& study, const std::vector<HumanCell>& cells,
                         const HumanCell& c) {
  const std::vector<std::string> produced = produced_measures(study);
  if (std::find(produced.begin(), produced.end(), c.measure) != produced.end()) return;
  int rows = 0;
  for (const auto& o : cells)
    if (o.measure == c.measure) rows += o.n + o.undefined;
  throw InputError(
      SourceLocation{c.file, c.line, c.measure_column},
      "column 'measure': \"" + c.measure + "\" is not a measure the study " + study.file +
          " produces (" +
          (rows == 1 ? std::string("1 row") : std::to_string(rows) + " rows, the first here") +
          "); expected one of: " + join(produced));
}

void check_human_cell(const Study& study, const HumanCell& c) {
  auto fail = [&](int column, const std::string& what) {
    return InputError(SourceLocation{c.file, c.line, column},
                      "the human data have a cell the study does not simulate: " + what);
  };
  std::vector<std::string> ids;
  for (const auto& g : study.groups) ids.push_back(g.id);
  if (std::find(ids.begin(), ids.end(), c.group) == ids.end())
    throw fail(c.group_column, "group \"" + c.group + "\" (the study's groups: " + join(ids) + ")");
  ids.clear();
  const Phase* phase = nullptr;
  for (const auto& p : study.phases) {
    ids.push_back(p.id);
    if (p.id == c.phase) phase = &p;
  }
  if (!phase)
    throw fail(c.phase_column, "phase \"" + c.phase + "\" (the study's phases: " + join(ids) + ")");
  if (c.session > phase->sessions)
    throw fail(c.session_column, "session " + std::to_string(c.session) + " of phase " + c.phase +
                                     " (it has " + std::to_string(phase->sessions) + " session" +
                                     (phase->sessions == 1 ? "" : "s") + ")");
  // A time within a session cannot be longer than the session (25 s in a 20 s session was
  // taken: review 2026-12-06).
  if (c.measure == "exploration_time" || c.measure == "procedure_time")
    for (std::size_t i = 0; i < c.values.size() && i < c.value_lines.size(); ++i)
      if (c.values[i] > phase->session_duration)
        throw InputError(SourceLocation{c.file, c.value_lines[i]},
                         "column 'value': " + c.measure + " " + format_shortest(c.values[i]) +
                             " s is longer than the sessions of phase " + c.phase + " (" +
                             format_shortest(phase->session_duration) +
                             " s): expected at most the session's duration");
}

CalibrationResult calibrate(const Study& study, const std::vector<HumanCell>& cells,
                            const CalibrateOptions& opt) {
  namespace pm = participants;
  if (opt.keys.empty()) throw InputError("--params: name at least one parameter to fit");
  for (std::size_t i = 0; i < opt.keys.size(); ++i)
    if (std::find(opt.keys.begin(), opt.keys.begin() + i, opt.keys[i]) != opt.keys.begin() + i)
      throw InputError(SourceLocation{"--params"},
                       "\"" + opt.keys[i] + "\" is named twice (expected each parameter once)");
  // --measures: every measure a session of the study stores (all are simulated).
  const std::vector<std::string> simulated = produced_measures(study);
  for (std::size_t i = 0; i < opt.measures.size(); ++i) {
    const std::string& m = opt.measures[i];
    if (std::find(simulated.begin(), simulated.end(), m) == simulated.end())
      throw InputError(
          SourceLocation{"--measures"},
          "\"" + m + "\" is not a measure of the study (expected one of: " + join(simulated) + ")");
    if (std::find(opt.measures.begin(), opt.measures.begin() + i, m) != opt.measures.begin() + i)
      throw InputError(SourceLocation{"--measures"},
                       "\"" + m + "\" is named twice (expected each measure once)");
  }
  CalibrationResult r;
  r.keys = opt.keys;
  const std::vector<std::string>& measures = opt.measures.empty() ? study.measures : opt.measures;
  // Cells of measures not fitted are ignored (docs/PARTICIPANTS.md: --measures selects), but
  // only measures the study produces: any other (a typo, another task's measure) would be
  // ignored silently, so it is an error at its first row.
  std::vector<HumanCell> used;
  for (const auto& c : cells) {
    check_human_measure(study, cells, c);
    if (std::find(measures.begin(), measures.end(), c.measure) != measures.end())
      used.push_back(c);
    else if (std::find(r.not_fitted.begin(), r.not_fitted.end(), c.measure) == r.not_fitted.end())
      r.not_fitted.push_back(c.measure);
  }
  if (used.empty()) {
    std::vector<std::string> in_data;
    for (const auto& c : cells)
      if (std::find(in_data.begin(), in_data.end(), c.measure) == in_data.end())
        in_data.push_back(c.measure);
    throw InputError("the human data have no cell of the measures to fit (" + join(measures) +
                         "); their measures: " + join(in_data) +
                         " (choose the measures with --measures)",
                     cells.empty() ? std::string() : cells.front().file);
  }
  // Every cell fitted must be one the study simulates: checked now, not after a simulation.
  for (const auto& c : used) {
    check_human_cell(study, c);
    // The loss compares SDs (and divides by n - 1): a fitted cell needs 2 values.
    if (c.n < 2)
      throw InputError(
          SourceLocation{c.file, c.line},
          "group " + c.group + ", phase " + c.phase + ", session " + std::to_string(c.session) +
              ", measure " + c.measure + ": " + std::to_string(c.n) + " participant" +
              (c.n == 1 ? "" : "s") + " with a value" +
              (c.value_lines.empty() ? "" : " (" + lines_text(c.value_lines) + ")") +
              (c.undefined_lines.empty()
                   ? std::string()
                   : ", " + std::to_string(c.undefined) + " without (empty or NA, " +
                         lines_text(c.undefined_lines) + ")") +
              "; expected at least 2 participants with a value in every fitted cell (an SD "
              "needs 2): add participants, or leave the measure out with --measures");
  }
  // --bounds: each names a fitted parameter once, within its table's bounds.
  for (std::size_t i = 0; i < opt.bounds.size(); ++i) {
    const ParamBound& b = opt.bounds[i];
    if (std::find(opt.keys.begin(), opt.keys.end(), b.name) == opt.keys.end())
      throw InputError(SourceLocation{"--bounds"}, "\"" + b.name +
                                                       "\" is not one of the fitted parameters "
                                                       "(--params: " +
                                                       join(opt.keys) + ")");
    for (std::size_t k = 0; k < i; ++k)
      if (opt.bounds[k].name == b.name)
        throw InputError(SourceLocation{"--bounds"},
                         "\"" + b.name + "\" is bounded twice; expected one NAME=LO:HI per name");
  }
  auto bound_of = [&](const std::string& k) -> const ParamBound* {
    for (const auto& b : opt.bounds)
      if (b.name == k) return &b;
    return nullptr;
  };
  std::vector<double> lo, hi, step;
  const pm::TraineeParams current = pm::trainee_params(study.participant_parameters, study.file);
  for (const auto& k : opt.keys) {
    const pm::ParamSpec* s = pm::find_param(pm::trainee_param_specs(), k);
    if (!s) {
      std::string names;
      for (const auto& x : pm::trainee_param_specs())
        names += std::string(names.empty() ? "" : ", ") + x.name;
      throw InputError("--params: unknown participant parameter \"" + k +
                       "\"; expected one of: " + names);
    }
    // A parameter of the other task would be "fitted" with a flat loss (pop_drop, and the
    // integer max_insertions searched as a real, for a palpation study; review 2026-12-07).
    if (pm::needle_task_param(*s) && study.task.kind != "needle_insertion")
      throw InputError(SourceLocation{"--params"},
                       "\"" + k +
                           "\" is a parameter of the needle-insertion task; this study's "
                           "task is " +
                           study.task.kind +
                           ", whose sessions do not use it (expected a parameter they use)");
    const double x0 = current.*(s->trainee);
    double l = s->min, h = s->max;
    if (const ParamBound* b = bound_of(k)) {
      if (b->lo < s->min || b->hi > s->max)
        throw InputError(SourceLocation{"--bounds"},
                         k + "=" + format_shortest(b->lo) + ":" + format_shortest(b->hi) +
                             " reaches outside the parameter's own bounds " +
                             format_shortest(s->min) + ":" + format_shortest(s->max) +
                             " (protocols/participants/params.cpp); expected a range within them");
      if (x0 < b->lo || x0 > b->hi)
        throw InputError(SourceLocation{"--bounds"},
                         k + "=" + format_shortest(b->lo) + ":" + format_shortest(b->hi) +
                             " does not hold the start value " + format_shortest(x0) +
                             " (the study's participant_model.parameters, else the default); "
                             "expected bounds around it, or set a start inside them in the study");
      l = b->lo;
      h = b->hi;
    }
    r.start.push_back(x0);
    lo.push_back(l);
    hi.push_back(h);
    // A quarter of the value (or a tenth of a bounded range when the value is 0), at most half
    // the bounds' range (a narrow --bounds would otherwise cut every simplex step at a bound).
    step.push_back(std::min(x0 != 0 ? 0.25 * std::abs(x0) : 0.1 * std::min(s->max - s->min, 1.0),
                            0.5 * (h - l)));
  }
  r.lo = lo;
  r.hi = hi;
  // --sim-n equal to every group's size is the study itself: the same fit, whose journal it
  // resumes (it was another fit's, simulated again from its start).
  const bool own_size = std::all_of(study.groups.begin(), study.groups.end(),
                                    [&](const auto& g) { return g.size == opt.sim_n; });
  const int sim_n = opt.sim_n > 0 && !own_size ? opt.sim_n : 0;
  Study base = study;
  if (sim_n > 0) {
    try {
      base = resized_study(study, sim_n, study.seed);  // same seed: common random numbers
    } catch (const InputError& e) {                    // "group size N: ..." is --sim-n's
      throw InputError(SourceLocation{"--sim-n"}, e.problems().front().what);
    }
  }
  auto with = [&](const std::vector<double>& x) {
    Study s = base;
    for (std::size_t i = 0; i < x.size(); ++i) s.participant_parameters[opt.keys[i]] = x[i];
    return s;
  };
  int evaluations = 0;
  double best = std::numeric_limits<double>::infinity();
  bool in_stencil = false;  // the standard errors' points: reported, not the optimiser's
  std::vector<std::vector<double>> stencil_points;  // those simulated for the first time there
  // Common random numbers make a simulation a deterministic function of x, so a point already
  // simulated (the start, which the optimiser evaluates again; the optimum, whose fit is
  // reported) is looked up, not simulated again: with exp2 at full size one simulation takes
  // minutes.
  std::map<std::vector<double>, std::pair<double, std::vector<CellFit>>> memo;
  // Every simulation is appended to the journal as it finishes; an evaluation found there is
  // taken instead (after the start, which is simulated and compared with its stored one).
  std::optional<CalibrationJournal> journal;
  if (!opt.journal.empty())
    journal.emplace(opt.journal, calibration_setup(study, sim_n, opt.keys, used), used);
  if (opt.warning)
    for (const auto& w : sd_floor_warnings(cells, measures)) opt.warning(w);
  if (journal && opt.notice) {
    const int k = journal->stored();
    opt.notice(k == 0 ? "each evaluation is appended to " + journal->path() +
                            " as it finishes (the same command resumes an interrupted fit)"
                      : journal->path() + " holds " + std::to_string(k) + " evaluation" +
                            (k == 1 ? "" : "s") +
                            " of this fit: the start is simulated again to check them, then "
                            "they are taken without simulating");
  }
  bool replay = false;
  auto simulate =
      [&](const std::vector<double>& x) -> const std::pair<double, std::vector<CellFit>>& {
    auto it = memo.find(x);
    if (it != memo.end()) return it->second;
    const auto* stored = journal ? journal->find(x) : nullptr;
    std::pair<double, std::vector<CellFit>> e;
    const bool from_journal = replay && stored;
    if (from_journal) {
      e = *stored;
      ++r.replayed;
    } else {
      e.first = moment_loss(with(x), used, opt.jobs, &e.second);
      if (journal && !stored) journal->append(x, e.first, e.second);
    }
    const double l = e.first;
    ++evaluations;
    if (!in_stencil) best = std::min(best, l);
    if (in_stencil) stencil_points.push_back(x);
    if (opt.progress) opt.progress(evaluations, l, best, x, in_stencil, from_journal);
    return memo.emplace(x, std::move(e)).first->second;
  };
  auto loss = [&](const std::vector<double>& x) { return simulate(x).first; };
  std::tie(r.loss_before, r.fit_before) = simulate(r.start);
  if (journal) {
    // The stored evaluations are this palplab's only if it simulates the start exactly as
    // stored (bit for bit: common random numbers make the loss a deterministic function).
    if (const auto* stored = journal->find(r.start);
        stored && !(stored->first == r.loss_before ||
                    (std::isnan(stored->first) && std::isnan(r.loss_before))))
      throw InputError(SourceLocation{"--journal"},
                       "\"" + journal->path() +
                           "\" holds this fit's evaluations, but its loss at "
                           "the start (" +
                           format_shortest(stored->first) + ") is not this palplab's (" +
                           format_shortest(r.loss_before) +
                           "): it was written by a palplab that simulates differently; remove "
                           "it (or give another --journal) to start the fit afresh");
    replay = true;
    r.journal_other_build = journal->other_build();
  }
  NelderMeadResult nm = nelder_mead(loss, r.start, step, lo, hi, opt.budget);
  r.fitted = nm.x;
  r.restarts = nm.restarts;
  r.converged = nm.converged;
  // A point whose loss equals the start's up to rounding is no better fit: moving there would
  // report a parameter change the data do not support (a parameter without effect on them).
  const double best_loss = simulate(r.fitted).first;
  const bool better =
      std::isfinite(r.loss_before)
          ? best_loss < r.loss_before - 1e-9 * std::max(1.0, std::abs(r.loss_before))
          : best_loss < r.loss_before;
  if (!better) {
    // Whether the optimiser ended at the start or at a point that ties with it: no point tried is
    // a better fit. Flat when every point tried has the start's loss up to rounding (the data do
    // not constrain the parameters), not when the start is a minimum its neighbours are worse than.
    r.kept_start = true;
    r.fitted = r.start;
    // One point (the start) says nothing about flatness: --budget 1 only evaluates the start.
    r.loss_flat = memo.size() > 1 && std::all_of(memo.begin(), memo.end(), [&](const auto& m) {
                    return std::abs(m.second.first - r.loss_before) <=
                           1e-9 * std::max(1.0, std::abs(r.loss_before));
                  });
  }
  r.points_tried = static_cast<int>(memo.size());
  std::tie(r.loss_after, r.fit_after) = simulate(r.fitted);
  r.se.assign(r.fitted.size(), kNaN);
  r.se_computed = opt.standard_errors && memo.size() > 1;  // --budget 1 fits nothing
  in_stencil = true;
  if (r.se_computed) standard_errors(r, step, lo, hi, loss);
  {
    std::vector<std::vector<double>> xs;
    std::vector<double> fs;
    // The points whose loss is within kQuadraticRegion of the fit's: where a quadratic loss lies
    // within 3 SEs of its minimum (Δloss = k² at k SEs), the scale the SEs are about. Points
    // farther out (the start of a long search, say) would make it the curvature of a region
    // where the loss need not be quadratic.
    for (const auto& [x, v] : memo)
      if (v.first <= r.loss_after + kQuadraticRegion) xs.push_back(x), fs.push_back(v.first);
    std::vector<bool> free(r.fitted.size());
    for (std::size_t i = 0; i < free.size(); ++i)
      free[i] = r.fitted[i] > lo[i] && r.fitted[i] < hi[i];
    r.se_quadratic = quadratic_se(xs, fs, r.fitted, step, free);
    r.quadratic_points = static_cast<int>(xs.size());
  }
  // A stencil point better than the fit: said, not adopted (see CalibrationResult).
  for (const auto& x : stencil_points) {
    const double v = memo.at(x).first;
    if (v < r.loss_after - 1e-9 * std::max(1.0, std::abs(r.loss_after)) &&
        (r.stencil_lower.empty() || v < r.stencil_lower_loss))
      r.stencil_lower = x, r.stencil_lower_loss = v;
  }
  r.evaluations = evaluations;
  r.budget = opt.budget;
  r.parameters = study.participant_parameters.is_object() ? study.participant_parameters
                                                          : nlohmann::json::object();
  for (std::size_t i = 0; i < r.keys.size(); ++i) r.parameters[r.keys[i]] = r.fitted[i];
  return r;
}

namespace {
// params.hpp with `keys` set to `values` (InputError when the file has no TraineeParams struct or
// one of the keys no member initialiser): what write_defaults writes, and check_defaults_file
// tries before the fit.
std::string defaults_text(const std::string& params_hpp, const std::vector<std::string>& keys,
                          const std::vector<double>& values) {
  std::string text;
  {
    std::ifstream in(params_hpp, std::ios::binary);
    if (!in) throw InputError("cannot read", params_hpp);
    std::ostringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const std::size_t begin = text.find("struct TraineeParams {");
  const std::size_t end = begin == std::string::npos ? begin : text.find("\n};", begin);
  if (end == std::string::npos)
    throw InputError("no `struct TraineeParams { ... };` found", params_hpp);
  std::string body = text.substr(begin, end - begin);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::regex member("(\\bdouble " + keys[i] + " = )([^;]+)(;)");
    std::smatch m;
    if (!std::regex_search(body, m, member))
      throw InputError("no member initialiser `double " + keys[i] + " = ...;`", params_hpp);
    char value[64];
    std::snprintf(value, sizeof value, "%.6g", values[i]);
    // Replace the value by position ("$1" followed by digits would read as another group).
    body.replace(m.position(2), m.length(2), value);
  }
  text.replace(begin, end - begin, body);
  return text;
}
}  // namespace

void check_defaults_file(const std::vector<std::string>& keys, const std::string& params_hpp) {
  defaults_text(params_hpp, keys, std::vector<double>(keys.size(), 0.0));
}

void write_defaults(const CalibrationResult& r, const std::string& params_hpp) {
  const std::string text = defaults_text(params_hpp, r.keys, r.fitted);
  write_file(params_hpp, text, "the file of parameter defaults");
}

nlohmann::json to_json(const CalibrationResult& r) {
  // A number that is not finite is written as null (never NaN, which is no JSON); a cell whose
  // simulated moments are undefined says why in "not_compared".
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  auto fits = [&](const std::vector<CellFit>& v) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& f : v) {
      nlohmann::json cell = {
          {"group", f.human.group},
          {"phase", f.human.phase},
          {"session", f.human.session},
          {"measure", f.human.measure},
          {"human",
           {{"n", f.human.n},
            {"undefined", f.human.undefined},
            {"mean", num(f.human.mean)},
            {"sd", num(f.human.sd)}}},
          {"simulated",
           {{"n", f.n_sim}, {"undefined", f.undefined}, {"mean", num(f.mean)}, {"sd", num(f.sd)}}},
          {"z_mean", num(f.z_mean)},
          {"z_sd", num(f.z_sd)}};
      if (const std::string why = not_compared_reason(f); !why.empty()) cell["not_compared"] = why;
      a.push_back(std::move(cell));
    }
    return a;
  };
  nlohmann::json fitted = nlohmann::json::object(), se = nlohmann::json::object(),
                 start = nlohmann::json::object(), bounds = nlohmann::json::object(),
                 se_quadratic = nlohmann::json::object();
  for (std::size_t i = 0; i < r.keys.size(); ++i) {
    fitted[r.keys[i]] = r.fitted[i];
    se[r.keys[i]] = num(r.se[i]);
    se_quadratic[r.keys[i]] = num(i < r.se_quadratic.size() ? r.se_quadratic[i] : kNaN);
    start[r.keys[i]] = r.start[i];
    if (i < r.lo.size()) bounds[r.keys[i]] = {r.lo[i], r.hi[i]};
  }
  // A lower loss found by the SE stencil: its point and loss, else null.
  nlohmann::json stencil_lower;
  if (!r.stencil_lower.empty()) {
    nlohmann::json at = nlohmann::json::object();
    for (std::size_t i = 0; i < r.keys.size(); ++i) at[r.keys[i]] = r.stencil_lower[i];
    stencil_lower = {{"parameters", at}, {"loss", num(r.stencil_lower_loss)}};
  }
  return {{"palplab_calibration", 1},
          {"fitted", fitted},
          {"standard_errors", se},
          {"standard_errors_quadratic", se_quadratic},
          {"quadratic_points", r.quadratic_points},
          {"start", start},
          {"bounds", bounds},
          {"loss_before", num(r.loss_before)},
          {"loss_after", num(r.loss_after)},
          {"measures_not_fitted", r.not_fitted},
          {"standard_errors_computed", r.se_computed},
          {"evaluations", r.evaluations},
          {"evaluations_from_journal", r.replayed},
          {"restarts", r.restarts},
          {"converged", r.converged},
          {"kept_start", r.kept_start},
          {"points_tried", r.points_tried},
          {"loss_flat", r.loss_flat},
          {"stencil_lower", stencil_lower},
          {"fit_before", fits(r.fit_before)},
          {"fit_after", fits(r.fit_after)},
          {"participant_model", {{"model", "pmm1"}, {"parameters", r.parameters}}}};
}

std::string to_text(const CalibrationResult& r) {
  std::ostringstream o;
  char buf[256];
  o << "fitted parameters (SE from the loss curvature at the fit; over the points: from the "
       "quadratic through the points tried near the fit):\n";
  for (std::size_t i = 0; i < r.keys.size(); ++i) {
    // A value on a bound is the bound's, not the data's: said, so it is not read as a fit.
    const bool bounded = i < r.lo.size();
    const char* at = !bounded                 ? ""
                     : r.fitted[i] <= r.lo[i] ? ", AT ITS LOWER BOUND"
                     : r.fitted[i] >= r.hi[i] ? ", AT ITS UPPER BOUND"
                                              : "";
    std::snprintf(
        buf, sizeof buf, "  %-24s %12.6g  (SE %s, start %s", r.keys[i].c_str(), r.fitted[i],
        std::isfinite(r.se[i]) ? std::to_string(r.se[i]).c_str()
        : !r.se_computed
            ? (r.points_tried <= 1 ? "not computed: nothing fitted" : "not computed (--no-se)")
        : *at ? "not estimable: on a bound"
              : "not estimable",
        format_shortest(r.start[i]).c_str());
    o << buf;
    if (bounded)
      o << ", bounds " << format_shortest(r.lo[i]) << ":" << format_shortest(r.hi[i]) << at;
    if (i < r.se_quadratic.size() && std::isfinite(r.se_quadratic[i])) {
      std::snprintf(buf, sizeof buf,
                    "; SE %g over the %d points with a loss within %g of the fit's",
                    r.se_quadratic[i], r.quadratic_points, kQuadraticRegion);
      o << buf;
    }
    o << ")\n";
  }
  // The stencil's curvature and the whole search's disagree: the loss is no one quadratic (rough
  // at the stencil's scale, where common random numbers leave steps, or far from quadratic over
  // the region searched).
  for (std::size_t i = 0; i < r.keys.size() && i < r.se_quadratic.size(); ++i)
    if (std::isfinite(r.se[i]) && std::isfinite(r.se_quadratic[i]) &&
        std::max(r.se[i], r.se_quadratic[i]) > 2 * std::min(r.se[i], r.se_quadratic[i])) {
      o << "the two SEs of " << r.keys[i]
        << " differ by more than 2x: the loss is not one quadratic near the fit (rough at the "
           "stencil's scale, where a press more or less moves it by a step, or curved otherwise "
           "farther out); neither describes it alone, the larger is the cautious one\n";
    }
  std::snprintf(buf, sizeof buf, "loss before %.4g, after %.4g (%d evaluation%s, %d restart%s)\n",
                r.loss_before, r.loss_after, r.evaluations, r.evaluations == 1 ? "" : "s",
                r.restarts, r.restarts == 1 ? "" : "s");
  o << buf;
  if (r.replayed > 0)
    o << r.replayed << " of the evaluations taken from the journal (not simulated again: an "
      << "earlier run of this fit stored them)\n";
  if (r.replayed > 0 && r.journal_other_build > 0)
    o << r.journal_other_build << " of the journal's lines of this fit were written by another "
      << "palplab build; used, since this one simulates the start exactly as stored\n";
  if (!r.converged && r.points_tried > 1)
    o << "STOPPED BY --budget " << r.budget
      << " before the search converged: the fitted values are the best point so far, not a "
         "minimum; run the same command with a larger --budget (its journal resumes the fit)\n";
  if (r.kept_start && r.points_tried <= 1)
    o << "only the start was simulated (--budget " << r.budget
      << "): its loss is reported, nothing was fitted\n";
  else if (r.kept_start)
    o << "no point tried lowered the loss beyond rounding: the start values are kept "
      << (r.loss_flat ? "(every point tried had the start's loss: the data do not constrain "
                        "these parameters here)\n"
                      : "(the start is the best point tried)\n");
  if (!r.stencil_lower.empty()) {
    std::snprintf(buf, sizeof buf, "the SE stencil found a lower loss, %.4g (fit %.4g), at",
                  r.stencil_lower_loss, r.loss_after);
    o << buf;
    for (std::size_t i = 0; i < r.keys.size(); ++i) {
      o << " " << r.keys[i] << " " << format_shortest(r.stencil_lower[i]);
      if (std::isfinite(r.se[i])) {
        std::snprintf(buf, sizeof buf, " (%+.2f SE from the fit)",
                      (r.stencil_lower[i] - r.fitted[i]) / r.se[i]);
        o << buf;
      }
    }
    o << ": the fit is no minimum at the stencil's scale. It is not moved there (its SEs are "
         "the fit's curvature); to fit from that point, set it in the study's "
         "\"participant_model\" parameters (the start) and run again\n";
  }
  o << "\n";
  o << "fit per group and measure (human mean ± SD vs simulated; z in SE units):\n";
  // "mean ± SD" in a fixed width, or "undefined" (explained on a line below the cell's).
  auto moments = [](const CellFit& f) {
    char m[64];
    if (std::isfinite(f.mean) && std::isfinite(f.sd))
      std::snprintf(m, sizeof m, "%8.3f ± %-7.3f", f.mean, f.sd);
    else
      std::snprintf(m, sizeof m, "%-18s", "undefined");
    return std::string(m);
  };
  for (std::size_t i = 0; i < r.fit_after.size(); ++i) {
    const CellFit& b = r.fit_before[i];
    const CellFit& f = r.fit_after[i];
    char z[64];
    if (std::isfinite(f.z_mean) && std::isfinite(f.z_sd))
      std::snprintf(z, sizeof z, "z_mean %6.2f z_sd %6.2f", f.z_mean, f.z_sd);
    else
      std::snprintf(z, sizeof z, "z not computed");
    // Names from the CSV may be of any length: padded, never cut.
    auto pad = [](const std::string& x, std::size_t w) {
      return x.size() < w ? x + std::string(w - x.size(), ' ') : x;
    };
    std::snprintf(buf, sizeof buf, "%8.3f ± %-7.3f", f.human.mean, f.human.sd);
    o << "  " << pad(f.human.group, 4) << " " << pad(f.human.phase, 18) << " "
      << pad(f.human.measure, 18) << " human " << buf << " before " << moments(b) << " after "
      << moments(f) << " " << z;
    if (f.undefined) o << " (" << f.undefined << " undefined)";
    o << "\n";
    const std::string why_before = not_compared_reason(b), why_after = not_compared_reason(f);
    if (!why_before.empty() && why_before == why_after)
      o << "       before and after: undefined (" << why_after << ")\n";
    else {
      if (!why_before.empty()) o << "       before: undefined (" << why_before << ")\n";
      if (!why_after.empty()) o << "       after: undefined (" << why_after << ")\n";
    }
  }
  if (!r.not_fitted.empty())
    o << "not fitted (in the human data, ignored; choose with --measures): " << join(r.not_fitted)
      << "\n";
  return o.str();
}

}  // namespace palplab::protocols
