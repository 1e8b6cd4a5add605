#pragma once
// The uncertainty tests' one way to write an input of a study spec.

#include <string>
#include <utility>
#include <vector>

#include "isowrench/uncertainty.hpp"

namespace isowrench {

/// An input named `name` with distribution `d`: `sd` per axis, or the support [lower, upper].
inline UncertainInput Input(const std::string& name, InputDistribution d, std::vector<double> sd,
                            double lower = 0, double upper = 0) {
  UncertainInput in;
  in.name = name;
  in.distribution = d;
  in.sd = std::move(sd);
  in.lower = lower;
  in.upper = upper;
  return in;
}

}  // namespace isowrench
