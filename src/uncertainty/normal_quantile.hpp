#pragma once
// Private: the central branch of the normal quantile (Wichura 1988, AS 241 PPND16, |q| <= 0.425,
// q = p - 0.5), written once for a double (NormalQuantile, sampling.cpp) and for a vector of
// doubles (the block draws of study.cpp): the same operations in the same order, so every lane
// rounds as the scalar does.

namespace isowrench {

template <class T>
inline T CentralNormalQuantile(const T& q) {
  const T r = 0.180625 - q * q;
  return q *
         (((((((2509.0809287301226727 * r + 33430.575583588128105) * r + 67265.770927008700853) *
                  r +
              45921.953931549871457) *
                 r +
             13731.693765509461125) *
                r +
            1971.5909503065514427) *
               r +
           133.14166789178437745) *
              r +
          3.387132872796366608) /
         (((((((5226.495278852545925 * r + 28729.085735721942674) * r + 39307.89580009271061) * r +
              21213.794301586595867) *
                 r +
             5394.1960214247511077) *
                r +
            687.1870074920579083) *
               r +
           42.313330701600911252) *
              r +
          1.0);
}

}  // namespace isowrench
