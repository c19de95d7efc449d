#pragma once
// Small, dependency-free SVG figures for the report: box plots with the individual values,
// per-participant dot plots, line plots with error bars (learning curves) and time series
// (force traces). Every figure is a complete, standalone <svg> document (valid XML, no
// scripts, no external references) that can be inlined into HTML or saved as a file.
// Non-finite values are skipped, never written as coordinates.
#include <string>
#include <vector>

namespace palplab::analysis {

// Escapes &, <, >, " and ' for XML/HTML text and attribute values.
std::string xml_escape(const std::string& s);

// Group colour i (a colour-blind-safe palette, Okabe & Ito 2008), cycled.
std::string group_colour(int i);

// Box plot per group (box Q1–Q3, median line, whiskers to min/max — the range) with every value
// as a jittered dot. names #groups; values #groups samples.
std::string svg_box_plot(const std::vector<std::string>& names,
                         const std::vector<std::vector<double>>& values, const std::string& title,
                         const std::string& y_label);

// One dot per participant (x = participant, sorted by group; colour = group).
struct ParticipantPoint {
  std::string participant;
  int group = 0;
  double value = 0;
};
std::string svg_participant_plot(const std::vector<std::string>& group_names,
                                 const std::vector<ParticipantPoint>& points,
                                 const std::string& title, const std::string& y_label);

// Lines through (x, y) per series with error bars (err may be empty or NaN = none): ±err, or
// the asymmetric [lo, hi] when lo/hi are given (e.g. a CI).
struct Series {
  std::string name;
  std::vector<double> x, y, err;
  std::vector<double> lo, hi;  // optional interval per point (same units as y); overrides err
  int colour = 0;
};
// A model's fitted line with a pointwise confidence band (drawn under the series, dashed line,
// translucent band, in the colour of group `colour`); x sorted ascending, lo/hi optional.
struct FittedLine {
  std::vector<double> x, y, lo, hi;
  int colour = 0;
};
// A labelled horizontal line across the plot (e.g. the ST / MPF / SFT force thresholds).
struct ReferenceLine {
  std::string label;
  double y = 0;
  std::string colour = "#555555";
};
// With markers, series are dodged horizontally (kDodgePixels apart, centred on the true x) so
// error bars of neighbouring groups at the same x never overlap.
inline constexpr double kDodgePixels = 7.0;
std::string svg_line_plot(const std::vector<Series>& series, const std::string& title,
                          const std::string& x_label, const std::string& y_label,
                          bool markers = true, const std::vector<ReferenceLine>& references = {},
                          const std::vector<FittedLine>& fits = {});

}  // namespace palplab::analysis
