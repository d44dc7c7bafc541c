// The residuals of the pose graph, for Ceres' autodiff (used by the optimiser, and by tests
// that check their Jacobians).
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ccir_mapping::core::pose_graph {

enum class SwitchFunction { kLinear, kSigmoid };

/// Relative-pose residual in 2D: S [R(theta_a)^T (p_b - p_a) - t; wrap(theta_b - theta_a - theta)].
struct Edge2D {
  Eigen::Vector3d measurement;
  Eigen::Matrix3d sqrt_information;

  template <class T>
  bool operator()(const T* a, const T* b, T* residual) const {
    using std::atan2, std::cos, std::sin;
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
/// q_b)].
struct Edge3D {
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
  Eigen::Matrix<double, 6, 6> sqrt_information;

  template <class T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* residual) const {
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(pa);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_b(pb);
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(qa);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(qb);
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
