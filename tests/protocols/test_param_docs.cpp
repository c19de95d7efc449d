// docs/PARTICIPANTS.md "Parameters and defaults" is what a researcher reads to know the model's
// defaults and what a study may set: its two tables (trainee, instructor) must be the code's
// (trainee_param_specs(), instructor_param_specs()). A review on 2026-12-05 found 14 ranges given
// as ">0"/"≥0" where the code bounds them above (hold_time 20 looked valid and is refused), and
// two defaults (extinction_rate, weber_fraction) the calibrations had changed long before.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "protocols/participants/params.hpp"

namespace {

struct DocRow {
  std::string def, range;
  int line = 0;
};

// The rows of the markdown table whose header cell starts with `header`: first cell's first word
// (a name, maybe followed by its symbol: "forgetting_tau τ") -> default and range cells.
std::map<std::string, DocRow> doc_table(const std::string& header) {
  std::ifstream in(std::string(PALPLAB_SOURCE_DIR) + "/docs/PARTICIPANTS.md");
  std::map<std::string, DocRow> rows;
  bool inside = false;
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (line.rfind("| " + header, 0) == 0) {
      inside = true;
      continue;
    }
    if (!inside) continue;
    if (line.rfind("|", 0) != 0) break;
    if (line.rfind("|---", 0) == 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    for (std::string c; std::getline(ss, c, '|');) {
      const auto a = c.find_first_not_of(' '), b = c.find_last_not_of(' ');
      cells.push_back(a == std::string::npos ? "" : c.substr(a, b - a + 1));
    }
    if (cells.size() < 3) continue;
    rows[cells[0].substr(0, cells[0].find(' '))] = {cells[1], cells[2], n};
  }
  return rows;
}

// A value written with d decimals stands for the code's value to within half its last digit.
void expect_shown(const std::string& shown, double value, const std::string& what) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(shown, &used);
  } catch (const std::exception&) {
  }
  ASSERT_TRUE(used > 0 && used == shown.size()) << what << ": \"" << shown << "\" is not a number";
  const auto dot = shown.find('.');
  const auto e = shown.find_first_of("eE");
  const int decimals =
      dot == std::string::npos
          ? 0
          : static_cast<int>((e == std::string::npos ? shown.size() : e) - dot - 1);
  const int exponent = e == std::string::npos ? 0 : std::stoi(shown.substr(e + 1));
  const double half_unit = 0.5 * std::pow(10.0, exponent - decimals) * (1 + 1e-9);
  EXPECT_LE(std::abs(v - value), half_unit)
      << what << ": the docs say " << shown << ", the code " << value;
}

void check_doc_table(const std::vector<palplab::protocols::participants::ParamSpec>& specs,
                     const std::string& header) {
  const auto rows = doc_table(header);
  ASSERT_FALSE(rows.empty()) << "no table \"| " << header << "\" in docs/PARTICIPANTS.md";
  EXPECT_EQ(rows.size(), specs.size()) << header;
  for (const auto& s : specs) {
    const auto it = rows.find(s.name);
    if (it == rows.end()) {
      ADD_FAILURE() << s.name << " is not in the docs' table \"" << header << "\"";
      continue;
    }
    const DocRow& r = it->second;
    const std::string where = "docs/PARTICIPANTS.md:" + std::to_string(r.line) + " " + s.name;
    expect_shown(r.def, s.value, where + " default");
    const auto dash = r.range.find("–");
    if (dash == std::string::npos) {
      ADD_FAILURE() << where << ": range \"" << r.range << "\" is not LO–HI (the code's bounds)";
      continue;
    }
    expect_shown(r.range.substr(0, dash), s.min, where + " lower bound");
    expect_shown(r.range.substr(dash + std::string("–").size()), s.max, where + " upper bound");
  }
  for (const auto& [name, row] : rows)
    EXPECT_NE(palplab::protocols::participants::find_param(specs, name), nullptr)
        << "docs/PARTICIPANTS.md:" << row.line << ": " << name << " is no parameter of the code";
}

}  // namespace

TEST(ParameterDocs, TheTraineeTableIsTheCodes) {
  check_doc_table(palplab::protocols::participants::trainee_param_specs(), "trainee parameter");
}

TEST(ParameterDocs, TheInstructorTableIsTheCodes) {
  check_doc_table(palplab::protocols::participants::instructor_param_specs(),
                  "instructor parameter");
}
