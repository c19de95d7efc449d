// NIST StRD accuracy: one-way ANOVA (F, R², residual SD) and univariate mean / SD, computed
// from the decimal text (exact centring, decimal.hpp). Each test prints the achieved number of
// correct significant digits, LRE = -log10(|x - c| / |c|), capped at 15 (the certified values
// have 15 digits). The issue asks >= 9 digits on SiRstv, SmLs01-06, AtmWtAg and >= 7 on
// SmLs07-09; exact decimal centring reaches ~14.6-15 everywhere, so 12 is asserted for ANOVA
// and 13 for the univariate sets, leaving margin for other compilers' rounding.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/decimal.hpp"
#include "analysis/descriptives.hpp"

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
