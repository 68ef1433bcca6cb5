// How precise an accuracy measured on n trials is: k of n right is a binomial proportion.
// Reports print its Wilson score interval (Wilson 1927; at the tens of queries a test
// split holds, Agresti & Coull 1998 show it keeps its coverage where the normal
// approximation p ± z·√(p(1−p)/n) does not) and the smallest difference between two
// such runs that is more than chance.
#pragma once

namespace drape {

// z of a two-sided 95 % interval (the standard normal's 97.5 % quantile).
inline constexpr double kZ95 = 1.959963984540054;

struct Proportion {
  double low = 0, high = 1;  // the interval, within [0, 1]
};

// The Wilson score interval of k successes in n trials (0 ≤ k ≤ n, n ≥ 1), at z.
// Throws drape::Error on bad counts.
Proportion WilsonInterval(int k, int n, double z = kZ95);

// The smallest difference between two proportions, each measured on n trials around p,
// that a two-sided z test at z calls more than chance: z·√(2·p·(1 − p)/n) (two
// independent runs of the same size, e.g. two recipe seeds' test splits). n ≥ 1.
double DifferenceBeyondChance(double p, int n, double z = kZ95);

// Trials per run for a difference d (> 0) around p to be more than chance at z:
// ⌈2·z²·p·(1 − p)/d²⌉ (at least 1).
int TrialsForDifference(double p, double d, double z = kZ95);

}  // namespace drape
