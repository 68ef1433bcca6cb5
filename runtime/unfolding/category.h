// The garment's category over a trial's hangs. The garment in the gripper does not change
// between steps, but one hang may not tell its category: the first hangs from a random
// grasp point, a shape the database (hung from anchors only) never shows. So the category
// by registration (recognition/category_fit.h) is decided again at every hang, and the
// trial's category is the one of the least score summed over the hangs so far.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace drape::unfolding {

// The category from the category-by-registration scores of a trial's hangs (per hang,
// score_c of the nearest categories that took part: a category's best fit over the hang's
// best, so 1 for the hang's best and every hang weighs alike). A category that took no
// part at a hang (the height gate or the two nearest categories by Eq. match left it out)
// counts that hang's largest score plus `absent_penalty` (>= 0): never better than one
// that was registered, and with a penalty worse, so that a category left out at the first
// hang does not win by one later hang that it fits a little better. The least sum decides;
// ties keep `standing`. "" when no hang has a score.
std::string SummedFitCategory(const std::vector<std::map<std::string, double>>& hangs, const std::string& standing,
                              double absent_penalty = 0);

}  // namespace drape::unfolding
