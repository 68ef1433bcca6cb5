// Choosing a setting by its count of right answers on selection queries (train +
// calibration), and what such a choice is worth: one implementation for drape
// calibrate's gates and weights, the category by registration and the twin discriminator.
#pragma once

#include <functional>
#include <vector>

namespace drape::recognition {

// The one-standard-error rule over counts of right answers of `n` selection queries (model
// selection, Breiman et al. 1984; Hastie et al., ESL §7.10): the first eligible candidate
// (in the caller's order, simplest first) whose count is within one standard error
// sqrt(p(1 − p)/n)·n of the best count (rate p). -1 when none is eligible or n <= 0.
int OneStandardError(const std::vector<int>& right, const std::vector<bool>& eligible, int n);

// The setting with the most right answers (ties: the first). -1 when `right` is empty.
int MostRight(const std::vector<int>& right);

// A selection rule: from each setting's count of right answers on `n` queries, the chosen
// setting (-1: none).
using SelectionRule = std::function<int(const std::vector<int>& right, int n)>;

// What a selection by `rule` is worth (a nested leave-one-out): `ok[i][g]` says whether
// query i is right with setting g (every row as long); each query is answered by the
// setting `rule` chooses from the counts on the other queries, and the right ones are
// counted (a query for which the rule chooses none counts as wrong). 0 without queries.
// `chosen` (optional): each query's setting. Throws drape::Error on rows of different
// lengths.
int NestedLeaveOneOut(const std::vector<std::vector<char>>& ok, const SelectionRule& rule,
                      std::vector<int>* chosen = nullptr);

}  // namespace drape::recognition
