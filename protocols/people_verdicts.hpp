#pragma once
// People's verdicts on a study's declared tests, and how reproducible they are (`palplab power
// --human FILE.csv`; docs/PARTICIPANTS.md "Agreement with people's verdicts").
#include <vector>

#include "protocols/calibrate.hpp"
#include "protocols/power.hpp"
#include "protocols/study.hpp"

namespace palplab::protocols {

// Runs the study's declared tests (run_declared_analyses) on the people's values in `cells`
// (read_human_cells), then replicates the people's study `resamples` times by resampling its
// participants with replacement within their groups (each drawn participant brings all its
// values, so measures stay paired as they were; Efron & Tibshirani 1993) and counts how often
// each verdict, and all of them together, come out as the people's. Seeded from the study seed
// (the same numbers on every run); 2000 resamples put a share near 0.4 within ±0.02 (95 %).
// InputError, naming the CSV, when its data hold a group the
// study does not have, or a tested group has fewer than 2 values in a tested cell.
PeopleVerdicts people_verdicts(const Study& study, const std::vector<HumanCell>& cells,
                               double alpha, long resamples = 2000);

}  // namespace palplab::protocols
