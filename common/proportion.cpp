#include "common/proportion.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/error.h"

namespace drape {

Proportion WilsonInterval(int k, int n, double z) {
  if (n < 1 || k < 0 || k > n || !(z > 0))
    throw Error("WilsonInterval: need 0 <= k <= n, n >= 1 and z > 0 (k " + std::to_string(k) + ", n " +
                std::to_string(n) + ")");
  const double p = double(k) / n, z2 = z * z;
  const double centre = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double half = z / (1 + z2 / n) * std::sqrt(p * (1 - p) / n + z2 / (4.0 * n * n));
  // Exactly 0 and 1 at k = 0 and k = n (the formula gives them up to rounding).
  return {k == 0 ? 0.0 : std::max(0.0, centre - half), k == n ? 1.0 : std::min(1.0, centre + half)};
}

double DifferenceBeyondChance(double p, int n, double z) {
  if (n < 1) throw Error("DifferenceBeyondChance: n must be >= 1");
  return z * std::sqrt(2 * p * (1 - p) / n);
}

int TrialsForDifference(double p, double d, double z) {
  if (!(d > 0)) throw Error("TrialsForDifference: the difference must be > 0");
  return std::max(1, static_cast<int>(std::ceil(2 * z * z * p * (1 - p) / (d * d))));
}

}  // namespace drape
