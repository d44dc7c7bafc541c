// The residuals of the pose graph, for Ceres' autodiff (used by the optimiser, and by tests
// that check their Jacobians).
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ccir_mapping::core::pose_graph {

enum class SwitchFunction { kLinear, kSigmoid };

/// A constant pose right-multiplied to a parameter block: a residual then constrains x * offset
/// (a windowed solve moves a held stretch of keyframes as one rigid block this way).
template <class T, class Offset>
void rightMultiply2D(const Offset& offset, T* x) {
  using std::cos, std::sin;
  const T c = cos(x[2]);
  const T s = sin(x[2]);
  const T dx = T(offset(0));
  const T dy = T(offset(1));
  x[0] += c * dx - s * dy;
  x[1] += s * dx + c * dy;
  x[2] += T(offset(2));
}

/// Relative-pose residual in 2D: S [R(theta_a)^T (p_b - p_a) - t; wrap(theta_b - theta_a - theta)],
/// with a and b right-multiplied by their offsets (x y theta) when `offsets` is set.
struct Edge2D {
  Eigen::Vector3d measurement;
  Eigen::Matrix3d sqrt_information;
  bool offsets = false;
  Eigen::Vector3d offset_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d offset_b = Eigen::Vector3d::Zero();

  template <class T>
  bool operator()(const T* a_in, const T* b_in, T* residual) const {
    using std::atan2, std::cos, std::sin;
    T a[3] = {a_in[0], a_in[1], a_in[2]};
    T b[3] = {b_in[0], b_in[1], b_in[2]};
    if (offsets) {
      rightMultiply2D(offset_a, a);
      rightMultiply2D(offset_b, b);
    }
    const T c = cos(a[2]);
    const T s = sin(a[2]);
    const T dx = b[0] - a[0];
    const T dy = b[1] - a[1];
    const T dtheta = b[2] - a[2] - T(measurement(2));
    Eigen::Matrix<T, 3, 1> e;
    e << c * dx + s * dy - T(measurement(0)), -s * dx + c * dy - T(measurement(1)),
        atan2(sin(dtheta), cos(dtheta));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> out(residual);
    out = sqrt_information.cast<T>() * e;
    return true;
  }
};

/// Relative-pose residual in 3D (algorithms.md 3.2): S [R_a^T (p_b - p_a) - t; 2 vec(q^-1 q_a^-1
/// q_b)], with a and b right-multiplied by their offsets when `offsets` is set.
struct Edge3D {
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
  Eigen::Matrix<double, 6, 6> sqrt_information;
  bool offsets = false;
  Eigen::Vector3d offset_a_translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond offset_a_rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d offset_b_translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond offset_b_rotation = Eigen::Quaterniond::Identity();

  template <class T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* residual) const {
    Eigen::Matrix<T, 3, 1> p_a = Eigen::Map<const Eigen::Matrix<T, 3, 1>>(pa);
    Eigen::Matrix<T, 3, 1> p_b = Eigen::Map<const Eigen::Matrix<T, 3, 1>>(pb);
    Eigen::Quaternion<T> q_a = Eigen::Map<const Eigen::Quaternion<T>>(qa);
    Eigen::Quaternion<T> q_b = Eigen::Map<const Eigen::Quaternion<T>>(qb);
    if (offsets) {
      p_a += q_a * offset_a_translation.cast<T>();
      q_a = q_a * offset_a_rotation.cast<T>();
      p_b += q_b * offset_b_translation.cast<T>();
      q_b = q_b * offset_b_rotation.cast<T>();
    }
    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    Eigen::Quaternion<T> delta = rotation.cast<T>().conjugate() * (q_a_inverse * q_b);
    if (delta.w() < T(0)) delta.coeffs() = -delta.coeffs();
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = q_a_inverse * (p_b - p_a) - translation.cast<T>();
    e.template tail<3>() = T(2) * delta.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> out(residual);
    out = sqrt_information.cast<T>() * e;
    return true;
  }
};

template <class T>
T switchValue(const T& s, SwitchFunction function) {
  using std::exp;
  return function == SwitchFunction::kLinear ? s : T(1) / (T(1) + exp(-s));
}

/// A loop residual scaled by psi(s) of its switch variable.
struct Switchable2D {
  Edge2D edge;
  SwitchFunction function;
  template <class T>
  bool operator()(const T* a, const T* b, const T* s, T* residual) const {
    edge(a, b, residual);
    const T psi = switchValue(s[0], function);
    for (int i = 0; i < 3; ++i) residual[i] *= psi;
    return true;
  }
};

struct Switchable3D {
  Edge3D edge;
  SwitchFunction function;
  template <class T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, const T* s,
                  T* residual) const {
    edge(pa, qa, pb, qb, residual);
    const T psi = switchValue(s[0], function);
    for (int i = 0; i < 6; ++i) residual[i] *= psi;
    return true;
  }
};

/// (gamma - s) / sigma: keeps each switch on unless its loop disagrees.
struct SwitchPrior {
  double gamma;
  double inverse_sigma;
  template <class T>
  bool operator()(const T* s, T* residual) const {
    residual[0] = (T(gamma) - s[0]) * T(inverse_sigma);
    return true;
  }
};

}  // namespace ccir_mapping::core::pose_graph
