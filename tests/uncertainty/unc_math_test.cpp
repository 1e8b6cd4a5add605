// The uncertainty studies' own elementary functions (src/uncertainty/unc_math.hpp) against
// std::exp and std::atan2, the bucketed exact percentiles (percentiles.hpp) against a full sort,
// and the generator (PhiloxUniforms' Philox4x64-10, Random123) against
// Random123's published known-answer vectors (kat_vectors, philox4x64 10).

#include "uncertainty/unc_math.hpp"

#include <Random123/philox.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "isowrench/uncertainty.hpp"
#include "uncertainty/percentiles.hpp"

namespace isowrench {
namespace {

// A fixed sequence of doubles in [lo, hi) (an LCG: the same points on every machine).
struct UncMathPoints {
  std::uint64_t state = 88172645463325252ull;
  double Next(double lo, double hi) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1p-53;
  }
};

TEST(UncertaintyMath, ExpMatchesStdExpWithinTwoUlp) {
  UncMathPoints points;
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double x = i % 2 ? points.Next(-708.0, 709.7) : points.Next(-3.0, 3.0);
    const double e = UncExp(x), r = std::exp(x);
    worst = std::max(worst, std::abs(e - r) / r);
  }
  EXPECT_LT(worst, 3.5e-16);
  EXPECT_EQ(UncExp(0.0), 1.0);
  EXPECT_EQ(UncExp(-1e4), 0.0);
  EXPECT_EQ(UncExp(1e4), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(UncExp(std::numeric_limits<double>::quiet_NaN())));
  // Subnormal results: the two-step scaling.
  EXPECT_NEAR(UncExp(-740.0), std::exp(-740.0), 1e-10 * std::exp(-740.0));
  // The four lanes are four independent scalar evaluations (the same bits in every lane).
  const double in[4] = {-2.5, 0.125, 7.0, -700.0};
  double out[4];
  UncExpLanes(in, out);
  for (int l = 0; l < 4; ++l) EXPECT_EQ(out[l], UncExp(in[l])) << l;
}

TEST(UncertaintyMath, Atan2MatchesStdAtan2WithinOneFemtoradian) {
  UncMathPoints points;
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double y = std::exp(points.Next(-30.0, 30.0)) * (points.Next(0, 1) < 0.5 ? -1 : 1);
    const double x = i % 5 == 0
                         ? points.Next(-1.0, 1.0)
                         : std::exp(points.Next(-30.0, 30.0)) * (points.Next(0, 1) < 0.5 ? -1 : 1);
    worst = std::max(worst, std::abs(UncAtan2(y, x) - std::atan2(y, x)));
  }
  EXPECT_LT(worst, 1e-15);
  // Near the branch points of the reduction (tan(3 pi / 8), 0.66) and the axes.
  for (double t :
       {0.66, 0.6600000000000001, 2.414213562373095, 2.4142135623730954, 1.0, 1e-300, 1e300}) {
    EXPECT_NEAR(UncAtan2(t, 1.0), std::atan2(t, 1.0), 1e-15) << t;
    EXPECT_NEAR(UncAtan2(t, -1.0), std::atan2(t, -1.0), 1e-15) << t;
  }
  EXPECT_EQ(UncAtan2(0.0, 1.0), 0.0);
  EXPECT_NEAR(UncAtan2(0.0, -1.0), std::atan2(0.0, -1.0), 1e-15);
  EXPECT_NEAR(UncAtan2(1.0, 0.0), std::atan2(1.0, 0.0), 1e-15);
  EXPECT_NEAR(UncAtan2(1.0, -0.0), std::atan2(1.0, -0.0), 1e-15);
  EXPECT_NEAR(UncAtan2(-1.0, -1.0), std::atan2(-1.0, -1.0), 1e-15);
  EXPECT_NEAR(UncAtan2(3.0, std::numeric_limits<double>::infinity()), 0.0, 1e-15);
  EXPECT_TRUE(std::isnan(UncAtan2(std::numeric_limits<double>::quiet_NaN(), 1.0)));
}

TEST(UncertaintyMath, Atan2LanesGiveTheScalarsBits) {
  // Every branch of the reduction in one vector, against the scalar one by one.
  UncMathPoints points;
  for (int i = 0; i < 20000; ++i) {
    UncMathV4 y, x, lanes;
    for (int l = 0; l < 4; ++l) {
      y[l] = l == 3 && i % 3 == 0 ? 0.0 : std::exp(points.Next(-5.0, 5.0));
      x[l] = (points.Next(0, 1) < 0.5 ? -1 : 1) * std::exp(points.Next(-5.0, 5.0));
    }
    UncAtan2NonNegativeY(y, x, lanes);
    for (int l = 0; l < 4; ++l) {
      double scalar;
      UncAtan2NonNegativeY(y[l], x[l], scalar);
      ASSERT_EQ(lanes[l], scalar) << y[l] << " " << x[l];
    }
  }
}

TEST(UncertaintyMath, PhiloxMatchesRandom123KnownAnswers) {
  // Random123's kat_vectors, "philox4x64 10": counter, key, result.
  struct Kat {
    std::uint64_t ctr[4], key[2], out[4];
  };
  const Kat kats[] = {
      {{0, 0, 0, 0},
       {0, 0},
       {0x16554d9eca36314cull, 0xdb20fe9d672d0fdcull, 0xd7e772cee186176bull,
        0x7e68b68aec7ba23bull}},
      {{~0ull, ~0ull, ~0ull, ~0ull},
       {~0ull, ~0ull},
       {0x87b092c3013fe90bull, 0x438c3c67be8d0224ull, 0x9cc7d7c69cd777b6ull,
        0xa09caebf594f0ba0ull}},
      {{0x243f6a8885a308d3ull, 0x13198a2e03707344ull, 0xa4093822299f31d0ull, 0x082efa98ec4e6c89ull},
       {0x452821e638d01377ull, 0xbe5466cf34e90c6cull},
       {0xa528f45403e61d95ull, 0x38c72dbd566e9788ull, 0xa5a1610e72fd18b5ull,
        0x57bd43b5e52b7fe6ull}},
  };
  for (const Kat& k : kats) {
    r123::Philox4x64 generator;
    const r123::Philox4x64::ctr_type c = {{k.ctr[0], k.ctr[1], k.ctr[2], k.ctr[3]}};
    const r123::Philox4x64::key_type key = {{k.key[0], k.key[1]}};
    const r123::Philox4x64::ctr_type r = generator(c, key);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(r[static_cast<size_t>(i)], k.out[i]) << i;
  }
  // PhiloxUniforms is that generator with key (seed, "isowunc1"): the top 53 bits, centred.
  r123::Philox4x64 generator;
  const r123::Philox4x64::ctr_type bits = generator({{5, 0, 2, 0}}, {{42, 0x69736f77756e6331ull}});
  const std::array<double, 4> u = PhiloxUniforms(42, 5, 0, 2);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(u[static_cast<size_t>(i)],
              (static_cast<double>(bits[static_cast<size_t>(i)] >> 11) + 0.5) * 0x1p-53);
  }
}

TEST(UncertaintyPercentiles, BucketedSelectionEqualsAFullSort) {
  // Type 7 from a sorted copy: the reference.
  const double levels[4] = {0.025, 0.5, 0.95, 0.975};
  auto sorted_percentiles = [&](std::vector<double> v, double* out) {
    std::sort(v.begin(), v.end());
    for (int k = 0; k < 4; ++k) {
      const double h = (static_cast<double>(v.size()) - 1.0) * levels[k];
      const size_t lo = static_cast<size_t>(std::floor(h));
      const size_t hi = std::min(v.size() - 1, lo + 1);
      out[k] = v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
    }
  };
  UncMathPoints points;
  for (int shape = 0; shape < 7; ++shape) {
    for (size_t n : {size_t{100}, size_t{8191}, size_t{8192}, size_t{20001}}) {
      std::vector<double> v(n);
      for (size_t i = 0; i < n; ++i) {
        const double u = points.Next(0.0, 1.0);
        switch (shape) {
          case 0: v[i] = u; break;
          case 1: v[i] = std::exp(20.0 * (u - 0.5)); break;  // log-uniform over 9 decades
          case 2: v[i] = i == 7 ? 1e300 : -3.0 + u; break;   // one huge outlier
          case 3: v[i] = std::floor(5.0 * u); break;         // five values, many ties
          case 4: v[i] = 2.5; break;                         // all equal
          case 5: v[i] = 1.0 + 1e-13 * u; break;             // a narrow spread
          default: v[i] = (i % 2 ? -1.0 : 1.0) * std::exp(-30.0 * u); break;  // both signs
        }
      }
      double expected[4], got[4];
      sorted_percentiles(v, expected);
      const auto extremes = std::minmax_element(v.begin(), v.end());
      BucketPercentiles(v, *extremes.first, *extremes.second, levels, 4, got);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(got[k], expected[k]) << shape << " " << n << " " << k;
    }
  }
}

}  // namespace
}  // namespace isowrench
