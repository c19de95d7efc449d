// NIST StRD accuracy: one-way ANOVA (F, R², residual SD) and univariate mean / SD, computed
// from the decimal text (exact centring, decimal.hpp). Each test prints the achieved number of
// correct significant digits, LRE = -log10(|x - c| / |c|), capped at 15 (the certified values
// have 15 digits). The issue asks >= 9 digits on SiRstv, SmLs01-06, AtmWtAg and >= 7 on
// SmLs07-09; exact decimal centring reaches ~14.6-15 everywhere, so 12 is asserted for ANOVA
// and 13 for the univariate sets, leaving margin for other compilers' rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/csv.hpp"
#include "analysis/decimal.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/grouped.hpp"

using namespace palplab::analysis;

namespace {

std::string data_path(const std::string& name) {
  return std::string(PALPLAB_SOURCE_DIR) + "/tests/data/nist/" + name;
}

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<std::string> lines;
  std::string l;
  while (std::getline(in, l)) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    lines.push_back(l);
  }
  return lines;
}

std::string last_token(const std::string& line) {
  std::istringstream ss(line);
  std::string t, last;
  while (ss >> t) last = t;
  return last;
}

double lre(double x, double c) {
  if (x == c) return 15;
  double r = -std::log10(std::fabs(x - c) / std::fabs(c));
  return std::min(15.0, r);
}

struct AnovaCase {
  const char* name;
  double min_digits;
};

class NistAnova : public ::testing::TestWithParam<AnovaCase> {};

TEST_P(NistAnova, FRSquaredResidualSd) {
  const auto& c = GetParam();
  auto lines = read_lines(data_path(std::string(c.name) + ".dat"));
  ASSERT_GT(lines.size(), 61u);
  double cert_f = 0, cert_r2 = 0, cert_sd = 0;
  for (size_t i = 0; i < 60; ++i) {
    const auto& l = lines[i];
    if (l.rfind("Between", 0) == 0) cert_f = std::stod(last_token(l));
    if (l.find("Certified R-Squared") != std::string::npos) cert_r2 = std::stod(last_token(l));
    if (l.find("Standard Deviation") != std::string::npos) cert_sd = std::stod(last_token(l));
  }
  ASSERT_GT(cert_f, 0);
  ASSERT_GT(cert_r2, 0);
  ASSERT_GT(cert_sd, 0);
  // Data from line 61: "treatment value"; group by treatment id in order of appearance.
  std::vector<std::string> ids, texts;
  for (size_t i = 60; i < lines.size(); ++i) {
    std::istringstream ss(lines[i]);
    std::string id, v;
    if (!(ss >> id >> v)) continue;
    ids.push_back(id);
    texts.push_back(v);
  }
  std::vector<std::string_view> views(texts.begin(), texts.end());
  auto cv = centre_decimals(views);
  std::map<std::string, int> index;
  Groups groups;
  for (size_t i = 0; i < ids.size(); ++i) {
    auto [it, fresh] = index.emplace(ids[i], static_cast<int>(groups.size()));
    if (fresh) groups.emplace_back();
    groups[it->second].push_back(cv.dev[i]);
  }
  Anova a = oneway_anova(groups);
  double lf = lre(a.F, cert_f), lr = lre(a.eta_squared, cert_r2), ls = lre(a.residual_sd, cert_sd);
  std::printf("[ NIST     ] %-8s LRE  F %5.1f   R2 %5.1f   residual SD %5.1f   (need %.0f)\n",
              c.name, lf, lr, ls, c.min_digits);
  EXPECT_GE(lf, c.min_digits);
  EXPECT_GE(lr, c.min_digits);
  EXPECT_GE(ls, c.min_digits);
}

INSTANTIATE_TEST_SUITE_P(StRD, NistAnova,
                         ::testing::Values(AnovaCase{"SiRstv", 12}, AnovaCase{"SmLs01", 12},
                                           AnovaCase{"SmLs02", 12}, AnovaCase{"SmLs03", 12},
                                           AnovaCase{"AtmWtAg", 12}, AnovaCase{"SmLs04", 12},
                                           AnovaCase{"SmLs05", 12}, AnovaCase{"SmLs06", 12},
                                           AnovaCase{"SmLs07", 12}, AnovaCase{"SmLs08", 12},
                                           AnovaCase{"SmLs09", 12}),
                         [](const auto& info) { return std::string(info.param.name); });

struct UnivCase {
  const char* file;
  double mean, sd;  // certified; 0 = read from the file
  double min_digits;
};

class NistUnivariate : public ::testing::TestWithParam<UnivCase> {};

TEST_P(NistUnivariate, MeanAndSd) {
  const auto& c = GetParam();
  auto lines = read_lines(data_path(c.file));
  double cert_mean = c.mean, cert_sd = c.sd;
  std::vector<std::string> texts;
  bool data = false;
  const bool csv = std::string(c.file).ends_with(".csv");
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto& l = lines[i];
    if (csv) {
      if (i > 0 && !l.empty()) texts.push_back(l);  // header "Results", then one digit a line
      continue;
    }
    if (!data) {
      if (l.find("Sample Mean") != std::string::npos)
        cert_mean = std::stod(l.substr(l.rfind(':') + 1));
      if (l.find("Sample Standard Deviation") != std::string::npos)
        cert_sd = std::stod(l.substr(l.rfind(':') + 1));
      if (!l.empty() && l.find_first_not_of('-') == std::string::npos) data = true;
      continue;
    }
    if (l.find_first_not_of(" \t") != std::string::npos) texts.push_back(last_token(l));
  }
  ASSERT_FALSE(texts.empty());
  std::vector<std::string_view> views(texts.begin(), texts.end());
  auto cv = centre_decimals(views);
  Descriptives d = describe(cv.dev, cv.centre);
  double lm = lre(d.mean, cert_mean), ls = lre(d.sd, cert_sd);
  std::printf("[ NIST     ] %-12s n %5d  LRE mean %5.1f   SD %5.1f   (need %.0f)\n", c.file, d.n,
              lm, ls, c.min_digits);
  EXPECT_GE(lm, c.min_digits);
  EXPECT_GE(ls, c.min_digits);
}

INSTANTIATE_TEST_SUITE_P(
    StRD, NistUnivariate,
    ::testing::Values(UnivCase{"PiDigits.csv", 4.53480000000000, 2.86733906028871, 13},
                      UnivCase{"Lottery.dat", 0, 0, 13}, UnivCase{"Lew.dat", 0, 0, 13},
                      UnivCase{"Mavro.dat", 0, 0, 13}, UnivCase{"Michelso.dat", 0, 0, 13},
                      UnivCase{"NumAcc1.dat", 0, 0, 13}, UnivCase{"NumAcc2.dat", 0, 0, 13},
                      UnivCase{"NumAcc3.dat", 0, 0, 13}, UnivCase{"NumAcc4.dat", 0, 0, 13}),
    [](const auto& info) {
      std::string s = info.param.file;
      return s.substr(0, s.find('.'));
    });

}  // namespace

// The values must not depend on the row order (issue 11: the reader once centred every value
// on the first row's). Each SmLs set goes through the CSV path of `palplab stats` (parse_csv,
// group_table) in its file order, reversed, with its extreme rows first and in 5 random
// permutations; every order keeps >= 9 digits of F, R² and the residual SD (12 asserted, as
// above), and the F of different orders agree to 1e-13.
namespace {
struct NistSet {
  std::vector<std::string> ids, texts;
  double f = 0, r2 = 0, sd = 0;
};
NistSet read_nist_anova(const std::string& name) {
  NistSet s;
  auto lines = read_lines(data_path(name + ".dat"));
  for (size_t i = 0; i < 60 && i < lines.size(); ++i) {
    const auto& l = lines[i];
    if (l.rfind("Between", 0) == 0) s.f = std::stod(last_token(l));
    if (l.find("Certified R-Squared") != std::string::npos) s.r2 = std::stod(last_token(l));
    if (l.find("Standard Deviation") != std::string::npos) s.sd = std::stod(last_token(l));
  }
  for (size_t i = 60; i < lines.size(); ++i) {
    std::istringstream ss(lines[i]);
    std::string id, v;
    if (ss >> id >> v) {
      s.ids.push_back(id);
      s.texts.push_back(v);
    }
  }
  return s;
}
Anova anova_of_rows(const NistSet& s, const std::vector<size_t>& order) {
  std::string csv = "treatment,value\n";
  for (size_t i : order) csv += s.ids[i] + "," + s.texts[i] + "\n";
  CsvTable t = parse_csv(csv, "shuffled.csv");
  GroupedData g = group_table(t, "value", "treatment", {});
  return oneway_anova(g.values);
}
}  // namespace

class NistShuffled : public ::testing::TestWithParam<const char*> {};

TEST_P(NistShuffled, EveryRowOrderKeepsTheDigits) {
  NistSet s = read_nist_anova(GetParam());
  ASSERT_GT(s.texts.size(), 20u);
  const size_t n = s.texts.size();
  std::vector<std::vector<size_t>> orders;
  std::vector<size_t> id(n);
  std::iota(id.begin(), id.end(), size_t{0});
  orders.push_back(id);
  orders.emplace_back(id.rbegin(), id.rend());
  // Largest value first, then smallest first (the order that broke the old reader).
  for (int extreme : {1, -1}) {
    std::vector<size_t> o = id;
    auto it = std::max_element(o.begin(), o.end(), [&](size_t a, size_t b) {
      return extreme * std::stod(s.texts[a]) < extreme * std::stod(s.texts[b]);
    });
    std::iter_swap(o.begin(), it);
    orders.push_back(o);
  }
  std::mt19937 rng(20261124);
  for (int r = 0; r < 5; ++r) {
    std::vector<size_t> o = id;
    std::shuffle(o.begin(), o.end(), rng);
    orders.push_back(o);
  }
  double worst = 15, f0 = 0;
  for (size_t k = 0; k < orders.size(); ++k) {
    Anova a = anova_of_rows(s, orders[k]);
    double lf = lre(a.F, s.f), lr = lre(a.eta_squared, s.r2), ls = lre(a.residual_sd, s.sd);
    worst = std::min({worst, lf, lr, ls});
    EXPECT_GE(lf, 12) << GetParam() << " order " << k;
    EXPECT_GE(lr, 12) << GetParam() << " order " << k;
    EXPECT_GE(ls, 12) << GetParam() << " order " << k;
    if (k == 0) f0 = a.F;
    EXPECT_NEAR(a.F, f0, 1e-13 * f0) << GetParam() << " order " << k;
  }
  std::printf("[ NIST     ] %-8s %zu row orders: worst LRE %.1f\n", GetParam(), orders.size(),
              worst);
}

INSTANTIATE_TEST_SUITE_P(StRD, NistShuffled,
                         ::testing::Values("SmLs01", "SmLs02", "SmLs03", "SmLs04", "SmLs05",
                                           "SmLs06", "SmLs07", "SmLs08", "SmLs09"));

// Values of very different magnitudes are read as written: a 1e15 (or a 9.97e36 fill value)
// in the first row must not round group B's 1.1 ... 1.4 (issue 11: they became 1.125 ... 1.375).
TEST(CsvValues, ReadAsWrittenWhateverComesFirst) {
  for (const char* big : {"1e15", "1e17", "9.97e36"}) {
    std::string rows = "B,1.1\nB,1.2\nB,1.3\nB,1.4\nC,1.6\nC,1.7\nC,1.9\nA,5\nA,7\n";
    for (bool big_first : {true, false}) {
      std::string csv = "group,value\n" + (big_first ? std::string("A,") + big + "\n" + rows
                                                     : rows + "A," + big + "\n");
      GroupedData g = group_table(parse_csv(csv, "t.csv"), "value", "group", {});
      ASSERT_EQ(g.names[1], big_first ? "B" : "C");
      const auto& b = g.values[big_first ? 1 : 0];
      ASSERT_EQ(b.size(), 4u);
      EXPECT_EQ(g.offset + b[0], 1.1) << big;
      EXPECT_EQ(g.offset + b[3], 1.4) << big;
      // SD of 1.1, 1.2, 1.3, 1.4 = sqrt(1/60) = 0.12909944487358056.
      EXPECT_NEAR(sd(b), 0.12909944487358056, 1e-15) << big;
    }
  }
}
