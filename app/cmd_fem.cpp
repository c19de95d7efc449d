// `palplab fem verify [--json] [--levels N]`: the FEM verification cases (issue 12). For each
// case the computed value, the analytic value, the relative error, its tolerance and the
// observed convergence order. Exit 0 when every case is within tolerance, 1 otherwise.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "engine/models/fem_verify.hpp"

namespace {

using json = nlohmann::ordered_json;

int run_verify(bool as_json, int levels) {
  if (levels < 4 || levels > 5)
    throw palplab::InputError("--levels must be between 4 and 5 (got " + std::to_string(levels) +
                              ")");
  palplab::engine::FemVerifyOptions opt;
  opt.cantilever_levels = levels;
  const auto checks = palplab::engine::run_fem_verification(opt);
  bool ok = true;
  for (const auto& c : checks) ok = ok && c.pass;
  if (as_json) {
    json cases = json::array();
    for (const auto& c : checks)
      cases.push_back({{"name", c.name},
                       {"quantity", c.quantity},
                       {"computed", c.computed},
                       {"analytic", c.analytic},
                       {"rel_error", c.rel_error},
                       {"tolerance", c.tolerance},
                       {"observed_order", std::isnan(c.order) ? json(nullptr) : json(c.order)},
                       {"pass", c.pass},
                       {"detail", c.detail}});
    std::cout << json{{"pass", ok}, {"cases", cases}}.dump(2) << "\n";
  } else {
    std::printf("%-26s %14s %14s %11s %9s %7s  %s\n", "case", "computed", "analytic", "rel_error",
                "tol", "order", "result");
    for (const auto& c : checks) {
      char order[16] = "-";
      if (!std::isnan(c.order)) std::snprintf(order, sizeof order, "%.2f", c.order);
      std::printf("%-26s %14.8g %14.8g %11.3g %9.1g %7s  %s\n", c.name.c_str(), c.computed,
                  c.analytic, c.rel_error, c.tolerance, order, c.pass ? "ok" : "FAIL");
      std::printf("    %s: %s\n", c.quantity.c_str(), c.detail.c_str());
    }
    std::printf("%s\n", ok ? "all cases within tolerance" : "SOME CASES OUTSIDE TOLERANCE");
  }
  return ok ? 0 : 1;
}

palplab::app::CommandRegistration reg{
    "fem", [](CLI::App& root, int* code) {
      auto* fem = root.add_subcommand("fem", "Tissue finite element model: verification");
      fem->require_subcommand(1);
      auto* verify = fem->add_subcommand(
          "verify", "Run the FEM verification cases (exit 1 if any is outside its tolerance)");
      auto json_out = std::make_shared<bool>(false);
      auto levels = std::make_shared<int>(4);
      verify->add_flag("--json", *json_out, "Print the cases as JSON");
      verify
          ->add_option("--levels", *levels,
                       "Cantilever refinement levels (4-5; elements through the thickness "
                       "1, 2, ..., 2^(levels-1); 5 takes minutes)")
          ->capture_default_str();
      verify->callback([=] { *code = run_verify(*json_out, *levels); });
    }};

}  // namespace
