#include "analysis/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "analysis/descriptives.hpp"

namespace palplab::analysis {

std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      case '\'':
        o += "&apos;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string group_colour(int i) {
  static const char* c[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                            "#E69F00", "#56B4E9", "#F0E442", "#000000"};
  return c[((i % 8) + 8) % 8];
}

namespace {

std::string svg_num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

std::string label(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// "Nice" tick positions covering [lo, hi] (1, 2, 5 × 10^k steps).
std::vector<double> ticks(double lo, double hi, int target = 6) {
  double span = hi - lo;
  double raw = span / target;
  double mag = std::pow(10, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * mag) {
      step = m * mag;
      break;
    }
  std::vector<double> t;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step)
    t.push_back(std::fabs(v) < 1e-12 * step ? 0.0 : v);
  return t;
}

// The plotting frame shared by every figure: 720 × 400, axes, ticks and labels.
struct Frame {
  double W = 720, H = 400, left = 70, right = 20, top = 40, bottom = 60;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  bool integer_x = false;  // x is a count (session number): no fractional ticks
  std::ostringstream body;

  double px(double x) const { return left + (x - x0) / (x1 - x0) * (W - left - right); }
  double py(double y) const { return H - bottom - (y - y0) / (y1 - y0) * (H - top - bottom); }

  void set_y(double lo, double hi) {
    if (!std::isfinite(lo) || !std::isfinite(hi)) lo = 0, hi = 1;
    if (hi <= lo) {
      double c = lo, d = std::max(1.0, std::fabs(c)) * 0.5;
      lo = c - d;
      hi = c + d;
    }
    double pad = 0.06 * (hi - lo);
    y0 = lo - pad;
    y1 = hi + pad;
  }

  std::string finish(const std::string& title, const std::string& x_label,
                     const std::string& y_label, bool numeric_x) {
    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
      << "\" viewBox=\"0 0 " << W << " " << H
      << "\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n";
    o << "<rect x=\"0\" y=\"0\" width=\"" << W << "\" height=\"" << H << "\" fill=\"white\"/>\n";
    o << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << xml_escape(title) << "</text>\n";
    // y axis with grid
    for (double t : ticks(y0, y1)) {
      o << "<line x1=\"" << svg_num(left) << "\" x2=\"" << svg_num(W - right) << "\" y1=\""
        << svg_num(py(t)) << "\" y2=\"" << svg_num(py(t)) << "\" stroke=\"#e5e5e5\"/>\n";
      o << "<text x=\"" << svg_num(left - 6) << "\" y=\"" << svg_num(py(t) + 4)
        << "\" text-anchor=\"end\">" << xml_escape(label(t)) << "</text>\n";
    }
    if (numeric_x)
      for (double t : ticks(x0, x1, 8)) {
        if (integer_x && std::fabs(t - std::round(t)) > 1e-9) continue;
        o << "<line x1=\"" << svg_num(px(t)) << "\" x2=\"" << svg_num(px(t)) << "\" y1=\""
          << svg_num(H - bottom) << "\" y2=\"" << svg_num(H - bottom + 5)
          << "\" stroke=\"black\"/>\n";
        o << "<text x=\"" << svg_num(px(t)) << "\" y=\"" << svg_num(H - bottom + 18)
          << "\" text-anchor=\"middle\">" << xml_escape(label(t)) << "</text>\n";
      }
    o << "<line x1=\"" << svg_num(left) << "\" x2=\"" << svg_num(left) << "\" y1=\"" << svg_num(top)
      << "\" y2=\"" << svg_num(H - bottom) << "\" stroke=\"black\"/>\n";
    o << "<line x1=\"" << svg_num(left) << "\" x2=\"" << svg_num(W - right) << "\" y1=\""
      << svg_num(H - bottom) << "\" y2=\"" << svg_num(H - bottom) << "\" stroke=\"black\"/>\n";
    o << "<text x=\"" << svg_num((left + W - right) / 2) << "\" y=\"" << svg_num(H - 14)
      << "\" text-anchor=\"middle\">" << xml_escape(x_label) << "</text>\n";
    o << "<text transform=\"translate(16," << svg_num((top + H - bottom) / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << xml_escape(y_label) << "</text>\n";
    o << body.str();
    o << "</svg>\n";
    return o.str();
  }
};

void range_of(const std::vector<double>& v, double& lo, double& hi) {
  for (double x : v)
    if (std::isfinite(x)) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
}

}  // namespace

std::string svg_box_plot(const std::vector<std::string>& names,
                         const std::vector<std::vector<double>>& values, const std::string& title,
                         const std::string& y_label) {
  Frame f;
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& v : values) range_of(v, lo, hi);
  f.set_y(lo, hi);
  const int k = static_cast<int>(names.size());
  f.x0 = 0;
  f.x1 = std::max(1, k);
  for (int g = 0; g < k; ++g) {
    std::vector<double> v;
    for (double x : values[g])
      if (std::isfinite(x)) v.push_back(x);
    const double cx = f.px(g + 0.5), half = std::min(60.0, (f.px(1) - f.px(0)) * 0.3);
    const std::string col = group_colour(g);
    f.body << "<text x=\"" << svg_num(cx) << "\" y=\"" << svg_num(f.H - f.bottom + 18)
           << "\" text-anchor=\"middle\">" << xml_escape(names[g]) << " (n = " << v.size()
           << ")</text>\n";
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    double q1 = quantile(v, 0.25), md = quantile(v, 0.5), q3 = quantile(v, 0.75);
    f.body << "<line x1=\"" << svg_num(cx) << "\" x2=\"" << svg_num(cx) << "\" y1=\""
           << svg_num(f.py(v.front())) << "\" y2=\"" << svg_num(f.py(v.back())) << "\" stroke=\""
           << col << "\"/>\n";
    for (double e : {v.front(), v.back()})
      f.body << "<line x1=\"" << svg_num(cx - half / 2) << "\" x2=\"" << svg_num(cx + half / 2)
             << "\" y1=\"" << svg_num(f.py(e)) << "\" y2=\"" << svg_num(f.py(e)) << "\" stroke=\""
             << col << "\"/>\n";
    f.body << "<rect x=\"" << svg_num(cx - half) << "\" y=\"" << svg_num(f.py(q3)) << "\" width=\""
           << svg_num(2 * half) << "\" height=\"" << svg_num(std::max(0.5, f.py(q1) - f.py(q3)))
           << "\" fill=\"" << col << "\" fill-opacity=\"0.15\" stroke=\"" << col << "\"/>\n";
    f.body << "<line x1=\"" << svg_num(cx - half) << "\" x2=\"" << svg_num(cx + half) << "\" y1=\""
           << svg_num(f.py(md)) << "\" y2=\"" << svg_num(f.py(md)) << "\" stroke=\"" << col
           << "\" stroke-width=\"2.5\"/>\n";
    // Deterministic jitter (golden-ratio sequence) so the figure is reproducible.
    for (size_t i = 0; i < values[g].size(); ++i) {
      double x = values[g][i];
      if (!std::isfinite(x)) continue;
      // Dots in a narrow band right of the box, inside the group's slot.
      double j = std::fmod(0.618033988749895 * (i + 1), 1.0);
      double dx = half + 4 + j * std::min(16.0, 0.35 * half);
      f.body << "<circle cx=\"" << svg_num(cx + dx) << "\" cy=\"" << svg_num(f.py(x))
             << "\" r=\"3\" fill=\"" << col << "\" fill-opacity=\"0.7\"/>\n";
    }
  }
  return f.finish(title, "group", y_label, false);
}

std::string svg_participant_plot(const std::vector<std::string>& group_names,
                                 const std::vector<ParticipantPoint>& points,
                                 const std::string& title, const std::string& y_label) {
  Frame f;
  std::vector<ParticipantPoint> p = points;
  std::stable_sort(p.begin(), p.end(), [](auto& a, auto& b) { return a.group < b.group; });
  double lo = INFINITY, hi = -INFINITY;
  for (auto& q : p)
    if (std::isfinite(q.value)) lo = std::min(lo, q.value), hi = std::max(hi, q.value);
  f.set_y(lo, hi);
  f.x0 = 0;
  f.x1 = std::max<size_t>(1, p.size());
  f.bottom = 90;
  for (size_t i = 0; i < p.size(); ++i) {
    double cx = f.px(i + 0.5);
    f.body << "<text transform=\"translate(" << svg_num(cx + 3) << ","
           << svg_num(f.H - f.bottom + 8) << ") rotate(60)\" font-size=\"9\">"
           << xml_escape(p[i].participant) << "</text>\n";
    if (!std::isfinite(p[i].value)) continue;
    f.body << "<circle cx=\"" << svg_num(cx) << "\" cy=\"" << svg_num(f.py(p[i].value))
           << "\" r=\"4\" fill=\"" << group_colour(p[i].group) << "\"/>\n";
  }
  for (size_t g = 0; g < group_names.size(); ++g)
    f.body << "<rect x=\"" << svg_num(f.W - 150) << "\" y=\"" << svg_num(f.top + 4 + 16 * g)
           << "\" width=\"10\" height=\"10\" fill=\"" << group_colour(static_cast<int>(g))
           << "\"/><text x=\"" << svg_num(f.W - 135) << "\" y=\"" << svg_num(f.top + 13 + 16 * g)
           << "\">" << xml_escape(group_names[g]) << "</text>\n";
  return f.finish(title, "participant", y_label, false);
}

std::string svg_line_plot(const std::vector<Series>& series, const std::string& title,
                          const std::string& x_label, const std::string& y_label, bool markers,
                          const std::vector<ReferenceLine>& references,
                          const std::vector<FittedLine>& fits) {
  Frame f;
  // Error bar of point i: [lo, hi] when given, else y ± err; NaN when there is none.
  auto bar = [](const Series& s, size_t i) -> std::pair<double, double> {
    if (i < s.lo.size() && i < s.hi.size() && std::isfinite(s.lo[i]) && std::isfinite(s.hi[i]))
      return {s.lo[i], s.hi[i]};
    if (i < s.err.size() && std::isfinite(s.err[i]) && s.err[i] > 0)
      return {s.y[i] - s.err[i], s.y[i] + s.err[i]};
    return {NAN, NAN};
  };
  double ylo = INFINITY, yhi = -INFINITY, xlo = INFINITY, xhi = -INFINITY;
  for (const auto& s : series) {
    range_of(s.x, xlo, xhi);
    for (size_t i = 0; i < s.y.size(); ++i) {
      if (!std::isfinite(s.y[i])) continue;
      auto [lo, hi] = bar(s, i);
      ylo = std::min({ylo, s.y[i], std::isfinite(lo) ? lo : s.y[i]});
      yhi = std::max({yhi, s.y[i], std::isfinite(hi) ? hi : s.y[i]});
    }
  }
  for (const auto& r : references)
    if (std::isfinite(r.y)) ylo = std::min(ylo, r.y), yhi = std::max(yhi, r.y);
  for (const auto& ft : fits) {
    range_of(ft.x, xlo, xhi);
    range_of(ft.y, ylo, yhi);
    range_of(ft.lo, ylo, yhi);
    range_of(ft.hi, ylo, yhi);
  }
  f.set_y(ylo, yhi);
  f.integer_x = markers;
  for (const auto& s : series)
    for (double x : s.x) f.integer_x = f.integer_x && std::fabs(x - std::round(x)) < 1e-12;
  if (!std::isfinite(xlo) || !std::isfinite(xhi)) xlo = 0, xhi = 1;
  if (xhi <= xlo) xlo -= 0.5, xhi += 0.5;
  double pad = markers ? 0.05 * (xhi - xlo) : 0;
  f.x0 = xlo - pad;
  f.x1 = xhi + pad;
  // Labels alternate between the left and the right end so close lines (ST 2.3 N, MPF 2.5 N)
  // do not print their labels on top of each other.
  for (size_t ri = 0; ri < references.size(); ++ri) {
    const auto& r = references[ri];
    if (!std::isfinite(r.y)) continue;
    const bool right = ri % 2 == 1;
    f.body << "<line x1=\"" << svg_num(f.left) << "\" x2=\"" << svg_num(f.W - f.right) << "\" y1=\""
           << svg_num(f.py(r.y)) << "\" y2=\"" << svg_num(f.py(r.y)) << "\" stroke=\"" << r.colour
           << "\" stroke-dasharray=\"6 4\"/>\n<text x=\""
           << svg_num(right ? f.W - f.right - 4 : f.left + 4) << "\" y=\"" << svg_num(f.py(r.y) - 3)
           << "\"" << (right ? " text-anchor=\"end\"" : "") << " fill=\"" << r.colour << "\">"
           << xml_escape(r.label) << "</text>\n";
  }
  // Fitted lines first so the observed means and their bars stay visible on top.
  for (const auto& ft : fits) {
    const std::string col = group_colour(ft.colour);
    const size_t m = std::min(ft.x.size(), ft.y.size());
    if (ft.lo.size() >= m && ft.hi.size() >= m && m >= 2) {
      std::ostringstream band;
      for (size_t i = 0; i < m; ++i)
        band << svg_num(f.px(ft.x[i])) << "," << svg_num(f.py(ft.hi[i])) << " ";
      for (size_t i = m; i-- > 0;)
        band << svg_num(f.px(ft.x[i])) << "," << svg_num(f.py(ft.lo[i])) << " ";
      f.body << "<polygon class=\"fitband\" fill=\"" << col
             << "\" fill-opacity=\"0.15\" stroke=\"none\" points=\"" << band.str() << "\"/>\n";
    }
    std::ostringstream pts;
    for (size_t i = 0; i < m; ++i)
      pts << svg_num(f.px(ft.x[i])) << "," << svg_num(f.py(ft.y[i])) << " ";
    f.body << "<polyline class=\"fit\" fill=\"none\" stroke=\"" << col
           << "\" stroke-width=\"1.5\" stroke-dasharray=\"5 3\" points=\"" << pts.str() << "\"/>\n";
  }
  const double n = static_cast<double>(series.size());
  for (size_t si = 0; si < series.size(); ++si) {
    const auto& s = series[si];
    const std::string col = group_colour(s.colour);
    const double dodge = markers ? (static_cast<double>(si) - (n - 1) / 2) * kDodgePixels : 0;
    std::ostringstream pts;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
        pts << svg_num(f.px(s.x[i]) + dodge) << "," << svg_num(f.py(s.y[i])) << " ";
    f.body << "<polyline fill=\"none\" stroke=\"" << col << "\" stroke-width=\"1.5\" points=\""
           << pts.str() << "\"/>\n";
    if (markers)
      for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        double cx = f.px(s.x[i]) + dodge;
        auto [lo, hi] = bar(s, i);
        if (std::isfinite(lo) && std::isfinite(hi))
          f.body << "<line class=\"errorbar\" x1=\"" << svg_num(cx) << "\" x2=\"" << svg_num(cx)
                 << "\" y1=\"" << svg_num(f.py(lo)) << "\" y2=\"" << svg_num(f.py(hi))
                 << "\" stroke=\"" << col << "\"/>\n";
        f.body << "<circle cx=\"" << svg_num(cx) << "\" cy=\"" << svg_num(f.py(s.y[i]))
               << "\" r=\"3\" fill=\"" << col << "\"/>\n";
      }
    f.body << "<rect x=\"" << svg_num(f.W - 150) << "\" y=\"" << svg_num(f.top + 4 + 16 * si)
           << "\" width=\"10\" height=\"10\" fill=\"" << col << "\"/><text x=\""
           << svg_num(f.W - 135) << "\" y=\"" << svg_num(f.top + 13 + 16 * si) << "\">"
           << xml_escape(s.name) << "</text>\n";
  }
  return f.finish(title, x_label, y_label, true);
}

}  // namespace palplab::analysis
