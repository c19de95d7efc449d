#pragma once
// People's verdicts on a study's declared tests, and how reproducible they are (`palplab power
// --human FILE.csv`; docs/PARTICIPANTS.md "Agreement with people's verdicts").
#include <string>
#include <vector>

#include "protocols/calibrate.hpp"
#include "protocols/power.hpp"
#include "protocols/study.hpp"

namespace palplab::protocols {

// Runs the study's declared tests (run_declared_analyses) on the people's values in `cells`
// (read_human_cells) and describes their groups (tested_group_descriptives); then, for every
// group size in `sizes`, draws `resamples` times what a right model would give (RightModel: a
// people's study and a replicate of n per group, both resampled by participants within groups;
// each drawn participant brings all its values, so measures stay paired as they were; Efron &
// Tibshirani 1993) and counts the draws whose replicate reaches the drawn people's verdicts,
// orders (a tie is not compared) and intervals. Seeded from the study seed and n (the same
// numbers on every run, whatever other sizes are asked for); 2000 draws put a share near 0.4
// within ±0.02 (95 %).
// InputError, naming the CSV, when its data hold a cell the study does not simulate, or a tested
// group has fewer than 2 values in a tested cell.
PeopleVerdicts people_verdicts(const Study& study, const std::vector<HumanCell>& cells,
                               double alpha, const std::vector<int>& sizes, long resamples = 2000);

// What is not compared, one line each (`palplab power` and `palplab merge` print them as
// warnings): a test undefined on the people's data (no verdict), a cell whose people's group
// means tie (no order to reach).
std::vector<std::string> people_warnings(const PeopleVerdicts& people);

}  // namespace palplab::protocols
