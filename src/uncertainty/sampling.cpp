// Random numbers of the uncertainty studies: Philox4x64-10 uniforms by counter, and the normal
// quantile (Wichura's AS 241).

#include <Random123/philox.h>

#include <cmath>
#include <limits>

#include "isowrench/uncertainty.hpp"
#include "uncertainty/normal_quantile.hpp"

namespace isowrench {

std::array<double, 4> PhiloxUniforms(std::uint64_t seed, std::uint64_t a, std::uint64_t b,
                                     std::uint64_t c) {
  // The key's second word tells this use of Philox from any other the project may add.
  static constexpr std::uint64_t kDomain = 0x69736f77756e6331ull;  // "isowunc1"
  r123::Philox4x64 generator;
  const r123::Philox4x64::ctr_type counter = {{a, b, c, 0}};
  const r123::Philox4x64::key_type key = {{seed, kDomain}};
  const r123::Philox4x64::ctr_type bits = generator(counter, key);
  std::array<double, 4> u;
  for (int k = 0; k < 4; ++k) {
    // The top 53 bits, centred in their interval: never 0 and never 1.
    u[static_cast<size_t>(k)] =
        (static_cast<double>(bits[static_cast<size_t>(k)] >> 11) + 0.5) * 0x1p-53;
  }
  return u;
}

double NormalQuantile(double p) {
  // Wichura, M. J. (1988) Algorithm AS 241: The percentage points of the normal distribution.
  // Applied Statistics 37, 477-484 (PPND16, about 16 digits).
  if (!(p > 0.0 && p < 1.0)) return std::numeric_limits<double>::quiet_NaN();
  const double q = p - 0.5;
  if (std::abs(q) <= 0.425) return CentralNormalQuantile(q);
  double r = q < 0 ? p : 1.0 - p;
  r = std::sqrt(-std::log(r));
  double value;
  if (r <= 5.0) {
    r -= 1.6;
    value = (((((((7.7454501427834140764e-4 * r + 0.0227238449892691845833) * r +
                  0.24178072517745061177) *
                     r +
                 1.27045825245236838258) *
                    r +
                3.64784832476320460504) *
                   r +
               5.7694972214606914055) *
                  r +
              4.6303378461565452959) *
                 r +
             1.42343711074968357734) /
            (((((((1.05075007164441684324e-9 * r + 5.475938084995344946e-4) * r +
                  0.0151986665636164571966) *
                     r +
                 0.14810397642748007459) *
                    r +
                0.68976733498510000455) *
                   r +
               1.6763848301838038494) *
                  r +
              2.05319162663775882187) *
                 r +
             1.0);
  } else {
    r -= 5.0;
    value = (((((((2.01033439929228813265e-7 * r + 2.71155556874348757815e-5) * r +
                  0.0012426609473880784386) *
                     r +
                 0.026532189526576123093) *
                    r +
                0.29656057182850489123) *
                   r +
               1.7848265399172913358) *
                  r +
              5.4637849111641143699) *
                 r +
             6.6579046435011037772) /
            (((((((2.04426310338993978564e-15 * r + 1.4215117583164458887e-7) * r +
                  1.8463183175100546818e-5) *
                     r +
                 7.868691311456132591e-4) *
                    r +
                0.0148753612908506148525) *
                   r +
               0.13692988092273580531) *
                  r +
              0.59983220655588793769) *
                 r +
             1.0);
  }
  return q < 0 ? -value : value;
}

}  // namespace isowrench
