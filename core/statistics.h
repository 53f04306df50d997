#pragma once
// One rule for a percentile wherever pvcap states one (the report, eval-sync's figures the README
// quotes, the benches), so that two p99s of the same numbers are the same number: the value at rank
// round(q * (n - 1)) of the values sorted, q in [0, 1] (0.5 the median of an odd count, 1 the
// largest). 0 for no values.
#include <vector>

namespace pvcap {

double percentile(std::vector<double> values, double q);

}  // namespace pvcap
