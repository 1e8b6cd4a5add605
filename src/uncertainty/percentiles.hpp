#pragma once
// Private: exact type 7 percentiles (Hyndman-Fan) of the values an uncertainty study keeps
// (study.cpp's FinishUncertainty; tests/uncertainty/unc_math_test.cpp compares them with a full
// sort).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace isowrench {

// Puts the order statistics of the ascending distinct `ranks` (each in [first, last)) at their
// places in v[first, last): the rank nearest the middle of the range first (nth_element), then the
// ranks on each side within their side only; a rank at the start of its range is that range's
// minimum. Any selection gives the same values (order statistics are unique, a +0 / -0 tie
// aside, which the interpolation below turns into +0 either way).
template <class Vector>
void SelectRanks(Vector& v, size_t first, size_t last, const size_t* ranks, int count) {
  if (count == 0) return;
  const size_t middle = first + (last - first) / 2;
  int m = 0;
  for (int k = 1; k < count; ++k) {
    const size_t dk = ranks[k] > middle ? ranks[k] - middle : middle - ranks[k];
    const size_t dm = ranks[m] > middle ? ranks[m] - middle : middle - ranks[m];
    if (dk < dm) m = k;
  }
  const size_t r = ranks[m];
  const auto begin = v.begin();
  if (r == first) {
    std::iter_swap(begin + static_cast<std::ptrdiff_t>(first),
                   std::min_element(begin + static_cast<std::ptrdiff_t>(first),
                                    begin + static_cast<std::ptrdiff_t>(last)));
  } else {
    std::nth_element(begin + static_cast<std::ptrdiff_t>(first),
                     begin + static_cast<std::ptrdiff_t>(r),
                     begin + static_cast<std::ptrdiff_t>(last));
  }
  SelectRanks(v, first, r, ranks, m);
  SelectRanks(v, r + 1, last, ranks + m + 1, count - m - 1);
}

// Type 7 percentiles of `v` at ascending `levels` (v is reordered): the order statistics at
// floor(h) and floor(h) + 1 of every level are selected at once (SelectRanks).
template <class Vector>
void ExactPercentiles(Vector& v, const double* levels, int count, double* out) {
  size_t ranks[8] = {};
  int n_ranks = 0;
  for (int k = 0; k < count && k < 4; ++k) {
    const double h = (static_cast<double>(v.size()) - 1.0) * levels[k];
    const size_t lo = static_cast<size_t>(std::floor(h));
    const size_t hi = std::min(v.size() - 1, lo + 1);
    for (size_t r : {lo, hi})
      if (n_ranks == 0 || ranks[n_ranks - 1] < r) ranks[n_ranks++] = r;
  }
  SelectRanks(v, 0, v.size(), ranks, n_ranks);
  for (int k = 0; k < count && k < 4; ++k) {
    const double h = (static_cast<double>(v.size()) - 1.0) * levels[k];
    const size_t lo = static_cast<size_t>(std::floor(h));
    const size_t hi = std::min(v.size() - 1, lo + 1);
    const double a = v[lo];
    double b = a;
    if (hi != lo) b = v[hi];
    out[k] = a + (h - static_cast<double>(lo)) * (b - a);
  }
}

// ExactPercentiles for many values with their extremes lo, hi known: one counting pass into
// kSelectBuckets buckets of equal width on [lo, hi] (the bucket of x, floor((x - lo) * scale),
// never decreases as x grows, so the values of rank r are in the bucket where the counts pass r),
// then a second pass keeps the values of the buckets holding the wanted ranks only, and
// nth_element selects each rank among them: the same order statistics as a full selection
// (32 instead of 39 instructions per value at 32,768 values). Falls back to ExactPercentiles
// below 8,192 values or when lo, hi give no usable scale.
constexpr long kSelectBuckets = 2048;
template <class Vector>
void BucketPercentiles(Vector& v, double lo, double hi, const double* levels, int count,
                       double* out) {
  const size_t n = v.size();
  const double scale = static_cast<double>(kSelectBuckets) / (hi - lo);
  if (n < 8192 || !(hi > lo) || !std::isfinite(scale) || !(scale > 0)) {
    ExactPercentiles(v, levels, count, out);
    return;
  }
  auto bucket = [&](double x) {
    const double d = (x - lo) * scale;
    if (!(d >= 0.0)) return 0L;  // (never: lo is the smallest value)
    const long b = static_cast<long>(d);
    return b < kSelectBuckets ? b : kSelectBuckets - 1;
  };
  std::vector<std::uint32_t> counts(static_cast<size_t>(kSelectBuckets), 0);
  for (const double x : v) ++counts[static_cast<size_t>(bucket(x))];
  // The wanted ranks (floor(h) and floor(h) + 1 of every level, as ExactPercentiles), their
  // buckets and their ranks within the bucket.
  size_t ranks[8] = {};
  int n_ranks = 0;
  for (int k = 0; k < count && k < 4; ++k) {
    const double h = (static_cast<double>(n) - 1.0) * levels[k];
    const size_t r_lo = static_cast<size_t>(std::floor(h));
    const size_t r_hi = std::min(n - 1, r_lo + 1);
    for (size_t r : {r_lo, r_hi})
      if (n_ranks == 0 || ranks[n_ranks - 1] < r) ranks[n_ranks++] = r;
  }
  long rank_bucket[8];
  size_t rank_offset[8];
  {
    size_t below = 0;
    long b = 0;
    for (int i = 0; i < n_ranks; ++i) {
      while (below + counts[static_cast<size_t>(b)] <= ranks[i])
        below += counts[static_cast<size_t>(b++)];
      rank_bucket[i] = b;
      rank_offset[i] = ranks[i] - below;
    }
  }
  // The kept buckets' values, bucket after bucket (start[w]: where kept bucket w begins).
  std::vector<signed char> slot(static_cast<size_t>(kSelectBuckets), -1);
  long kept[8];
  size_t start[9];
  int n_kept = 0;
  start[0] = 0;
  for (int i = 0; i < n_ranks; ++i) {
    if (n_kept > 0 && kept[n_kept - 1] == rank_bucket[i]) continue;
    kept[n_kept] = rank_bucket[i];
    slot[static_cast<size_t>(rank_bucket[i])] = static_cast<signed char>(n_kept);
    start[n_kept + 1] = start[n_kept] + counts[static_cast<size_t>(rank_bucket[i])];
    ++n_kept;
  }
  std::vector<double> selected(start[n_kept]);
  size_t fill[8];
  for (int w = 0; w < n_kept; ++w) fill[w] = start[w];
  for (const double x : v) {
    const int w = slot[static_cast<size_t>(bucket(x))];
    if (w >= 0) selected[fill[w]++] = x;
  }
  double value[8];
  for (int i = 0; i < n_ranks; ++i) {
    int w = 0;
    while (kept[w] != rank_bucket[i]) ++w;
    double* first = selected.data() + start[w];
    double* last = selected.data() + start[w + 1];
    std::nth_element(first, first + rank_offset[i], last);
    value[i] = first[rank_offset[i]];
  }
  for (int k = 0; k < count && k < 4; ++k) {
    const double h = (static_cast<double>(n) - 1.0) * levels[k];
    const size_t r_lo = static_cast<size_t>(std::floor(h));
    const size_t r_hi = std::min(n - 1, r_lo + 1);
    int i = 0;
    while (ranks[i] != r_lo) ++i;
    const double a = value[i];
    double b = a;
    if (r_hi != r_lo) b = value[i + 1];
    out[k] = a + (h - static_cast<double>(r_lo)) * (b - a);
  }
}

}  // namespace isowrench
