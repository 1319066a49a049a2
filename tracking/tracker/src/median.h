// The median of a list of numbers, for the tracker's robust statistics.
#pragma once

#include <algorithm>
#include <vector>

namespace stillmap {

// The upper median (the middle one of an odd count) of a copy of `values`, not empty.
inline double Median(std::vector<double> values) {
  const auto middle = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace stillmap
