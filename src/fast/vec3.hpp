#pragma once
// Private: the 3-vector of the engine (fast/kernel.hpp), one type per lane type T, so that the
// kinematics is written once over vectors and frames:
//   T = double (one posture): Vec3 is one V4 holding x, y, z in lanes 0, 1, 2, so that adding,
//     scaling or turning a vector is one instruction. Lane 3 is never part of a result.
//   T = V4 (four postures, one per lane): Vec3 is Lanes3, one V4 per component, as three
//     scalars would be.
// A frame is three Vec3 columns (M[c] = column c of the rotation). The one-posture vector is the
// bare V4, not a struct around it: a struct holding a 32-byte vector is laid out for the
// baseline target, where it has no vector mode, and GCC then copies it through memory in the
// AVX2 clone too. These inline helpers return V4 by value; the files that include this header
// build with -Wno-psabi (the ABI note concerns calls between differently compiled units; every
// function here is inlined).

#include <Eigen/Core>
#include <type_traits>

#include "fast/simd.hpp"

namespace isowrench {

/// Four postures' 3-vector: component c of posture l at c[c][l].
struct Lanes3 {
  V4 c[3];
};

/// The types of the engine for lane type T: its 3-vector (see above) and the result of a
/// comparison (bool for one posture, a lane mask with all bits set where true for the lanes).
template <class T>
struct LaneTypes;
template <>
struct LaneTypes<double> {
  using Vec3 = V4;
  using Mask = bool;
};
template <>
struct LaneTypes<V4> {
  using Vec3 = Lanes3;
  using Mask = V4i;
};
template <class T>
using Vec3 = typename LaneTypes<T>::Vec3;

// ---- Making vectors ----

/// (0, 0, 0).
template <class T>
ISOWRENCH_INLINE Vec3<T> Zero3() {
  if constexpr (std::is_same_v<T, double>) {
    return ISOWRENCH_V4_SPLAT(0.0);
  } else {
    return {{ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0), ISOWRENCH_V4_SPLAT(0.0)}};
  }
}
/// The constant (p[0], p[1], p[2]), the same in every lane.
template <class T>
ISOWRENCH_INLINE Vec3<T> Constant3(const double* p) {
  if constexpr (std::is_same_v<T, double>) {
    return V4{p[0], p[1], p[2], p[2]};  // (lane 3 a copy of z: no zeroing instruction)
  } else {
    return {{ISOWRENCH_V4_SPLAT(p[0]), ISOWRENCH_V4_SPLAT(p[1]), ISOWRENCH_V4_SPLAT(p[2])}};
  }
}
/// Unit vector along axis `axis` (0, 1, 2).
inline constexpr double kUnit3[3][4] = {
    {1.0, 0.0, 0.0, 0.0}, {0.0, 1.0, 0.0, 0.0}, {0.0, 0.0, 1.0, 0.0}};
template <class T>
ISOWRENCH_INLINE Vec3<T> Unit3(int axis) {
  if constexpr (std::is_same_v<T, double>) {  // one load (GCC builds {1, 0, 0, 0} lane by lane)
    V4 e;
    __builtin_memcpy(&e, kUnit3[axis], sizeof e);
    return e;
  } else {
    return Constant3<T>(kUnit3[axis]);
  }
}

// ---- Arithmetic (one posture: V4's own +, -, * by a double) ----

ISOWRENCH_INLINE Lanes3 operator+(const Lanes3& a, const Lanes3& b) {
  return {{a.c[0] + b.c[0], a.c[1] + b.c[1], a.c[2] + b.c[2]}};
}
ISOWRENCH_INLINE Lanes3 operator-(const Lanes3& a, const Lanes3& b) {
  return {{a.c[0] - b.c[0], a.c[1] - b.c[1], a.c[2] - b.c[2]}};
}
ISOWRENCH_INLINE Lanes3 operator-(const Lanes3& a) { return {{-a.c[0], -a.c[1], -a.c[2]}}; }
/// a s (s: one number per posture).
ISOWRENCH_INLINE Lanes3 operator*(const Lanes3& a, const V4& s) {
  return {{a.c[0] * s, a.c[1] * s, a.c[2] * s}};
}
ISOWRENCH_INLINE Lanes3& operator+=(Lanes3& a, const Lanes3& b) {
  a = a + b;
  return a;
}
/// dst = src, component by component: GCC keeps a loop-carried Lanes3 in registers only when it
/// is assigned field by field (a whole-struct copy goes through the stack).
ISOWRENCH_INLINE void Set(V4& dst, const V4& src) { dst = src; }
ISOWRENCH_INLINE void Set(Lanes3& dst, const Lanes3& src) {
  dst.c[0] = src.c[0];
  dst.c[1] = src.c[1];
  dst.c[2] = src.c[2];
}
/// (a_x b_x, a_y b_y, a_z b_z).
ISOWRENCH_INLINE V4 Hadamard(const V4& a, const V4& b) { return a * b; }
ISOWRENCH_INLINE Lanes3 Hadamard(const Lanes3& a, const Lanes3& b) {
  return {{a.c[0] * b.c[0], a.c[1] * b.c[1], a.c[2] * b.c[2]}};
}
/// out = a . b.
ISOWRENCH_INLINE void Dot(const V4& a, const V4& b, double& out) {
  const V4 t = a * b;
  out = (t[0] + t[1]) + t[2];
}
ISOWRENCH_INLINE void Dot(const Lanes3& a, const Lanes3& b, V4& out) {
  out = a.c[0] * b.c[0] + a.c[1] * b.c[1] + a.c[2] * b.c[2];
}
/// a x b. One posture: (a b_yzx - a_yzx b)_yzx, three shuffles.
ISOWRENCH_INLINE V4 Cross(const V4& a, const V4& b) {
  const V4 a_yzx = __builtin_shufflevector(a, a, 1, 2, 0, 3);
  const V4 b_yzx = __builtin_shufflevector(b, b, 1, 2, 0, 3);
  const V4 t = a * b_yzx - a_yzx * b;  // (a x b)_zxy
  return __builtin_shufflevector(t, t, 1, 2, 0, 3);
}
ISOWRENCH_INLINE Lanes3 Cross(const Lanes3& a, const Lanes3& b) {
  return {{a.c[1] * b.c[2] - a.c[2] * b.c[1], a.c[2] * b.c[0] - a.c[0] * b.c[2],
           a.c[0] * b.c[1] - a.c[1] * b.c[0]}};
}
/// Component i (0, 1, 2).
ISOWRENCH_INLINE double Component(const V4& a, int i) { return a[i]; }
ISOWRENCH_INLINE const V4& Component(const Lanes3& a, int i) { return a.c[i]; }

// ---- Frames ----

/// M a for a frame M (three columns) and a constant a (3 numbers, the same in every lane).
ISOWRENCH_INLINE V4 Transform(const V4* M, const double* a) {
  return (M[0] * a[0] + M[1] * a[1]) + M[2] * a[2];
}
ISOWRENCH_INLINE Lanes3 Transform(const Lanes3* M, const double* a) {
  Lanes3 out;
  ISOWRENCH_UNROLL
  for (int r = 0; r < 3; ++r) out.c[r] = M[0].c[r] * a[0] + M[1].c[r] * a[1] + M[2].c[r] * a[2];
  return out;
}
/// M a for a frame M and a vector a (one per posture).
ISOWRENCH_INLINE V4 Rotate(const V4* M, const V4& a) {
  const V4 x = __builtin_shufflevector(a, a, 0, 0, 0, 0);
  const V4 y = __builtin_shufflevector(a, a, 1, 1, 1, 1);
  const V4 z = __builtin_shufflevector(a, a, 2, 2, 2, 2);
  return (M[0] * x + M[1] * y) + M[2] * z;
}
ISOWRENCH_INLINE Lanes3 Rotate(const Lanes3* M, const Lanes3& a) {
  Lanes3 out;
  ISOWRENCH_UNROLL
  for (int r = 0; r < 3; ++r)
    out.c[r] = M[0].c[r] * a.c[0] + M[1].c[r] * a.c[1] + M[2].c[r] * a.c[2];
  return out;
}
/// M <- M R0 (R0 a constant rotation).
template <class V>
ISOWRENCH_INLINE void MultiplyRotation(V* M, const Eigen::Matrix3d& R0) {
  const V P[3] = {Transform(M, R0.data()), Transform(M, R0.data() + 3),
                  Transform(M, R0.data() + 6)};
  ISOWRENCH_UNROLL
  for (int c = 0; c < 3; ++c) M[c] = P[c];
}
/// out = the transpose of frame M.
ISOWRENCH_INLINE void Transpose(const V4* M, V4* out) {
  const V4 zero = ISOWRENCH_V4_SPLAT(0.0);
  const V4 t0 = __builtin_shufflevector(M[0], M[1], 0, 4, 2, 6);  // M00 M01 M20 M21
  const V4 t1 = __builtin_shufflevector(M[0], M[1], 1, 5, 3, 7);  // M10 M11
  const V4 t2 = __builtin_shufflevector(M[2], zero, 0, 4, 2, 6);  // M02 0 M22 0
  const V4 t3 = __builtin_shufflevector(M[2], zero, 1, 5, 3, 7);  // M12 0
  out[0] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  out[1] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  out[2] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
}
ISOWRENCH_INLINE void Transpose(const Lanes3* M, Lanes3* out) {
  ISOWRENCH_UNROLL
  for (int r = 0; r < 3; ++r) {
    ISOWRENCH_UNROLL
    for (int c = 0; c < 3; ++c) out[r].c[c] = M[c].c[r];
  }
}

// ---- One posture: to and from Eigen ----

inline Eigen::Vector3d ToEigen(const V4& a) { return Eigen::Vector3d(a[0], a[1], a[2]); }
ISOWRENCH_INLINE V4 FromEigen(const Eigen::Vector3d& a) { return Constant3<double>(a.data()); }
/// The frame M (three columns) as a matrix.
inline Eigen::Matrix3d ToEigen(const V4* M) {
  Eigen::Matrix3d out;
  for (int c = 0; c < 3; ++c) out.col(c) = ToEigen(M[c]);
  return out;
}

}  // namespace isowrench
