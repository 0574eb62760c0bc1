// The Ceres residuals of a mesh fit (mesh_fit.cpp): the linear data, smoothness and temporal
// terms, the per-face rigidity of each edge, and the barriers that keep every corner convex and
// every edge from collapsing. Internal to core/fit.
#pragma once

#include <ceres/ceres.h>

#include <cmath>
#include <vector>

#include "core/fit/mesh_fit.h"

namespace tesswave::fit_detail {

// beta's weight: a corner at half its margin costs as much as a match 10 px off.
constexpr double kBarrierWeight = 10.0;

// A residual linear in the vertex blocks, sum_k w_k x_k - target: data, smoothness and temporal
// terms. Its Jacobian is w_k I per block, so it needs no automatic differentiation.
class LinearCost : public ceres::CostFunction {
  public:
    LinearCost(std::vector<double> weights, Vec2 target)
        : weights_(std::move(weights)), target_(target) {
        set_num_residuals(2);
        mutable_parameter_block_sizes()->assign(weights_.size(), 2);
    }
    bool Evaluate(double const* const* x, double* residual, double** jacobians) const override {
        residual[0] = -target_.x;
        residual[1] = -target_.y;
        for (size_t k = 0; k < weights_.size(); ++k) {
            residual[0] += weights_[k] * x[k][0];
            residual[1] += weights_[k] * x[k][1];
            if (jacobians && jacobians[k]) {
                double* J = jacobians[k];
                J[0] = J[3] = weights_[k];
                J[1] = J[2] = 0.0;
            }
        }
        return true;
    }

  private:
    std::vector<double> weights_;
    Vec2 target_;
};

// Edge (i, j) of a face against the face's transform of the same edge in r: ARAP's S_f is the
// rotation by s[0], ASAP's the rotation and scale [s0 -s1; s1 s0].
template <Rigidity kind>
struct EdgeRigidity {
    Vec2 edge;  // r_j - r_i
    double weight;
    template <class T>
    bool operator()(const T* xi, const T* xj, const T* s, T* residual) const {
        using std::cos, std::sin;
        T a, b;
        if constexpr (kind == Rigidity::as_rigid) {
            a = cos(s[0]), b = sin(s[0]);
        } else {
            a = s[0], b = s[1];
        }
        residual[0] = weight * (xj[0] - xi[0] - (a * edge.x - b * edge.y));
        residual[1] = weight * (xj[1] - xi[1] - (b * edge.x + a * edge.y));
        return true;
    }
};

// beta(sin theta) at one corner; a reflex or straight corner cannot be evaluated, which makes
// Ceres reject the step that produced it.
struct CornerBarrier {
    double margin;
    template <class T>
    bool operator()(const T* prev, const T* here, const T* next, T* residual) const {
        const T ax = here[0] - prev[0], ay = here[1] - prev[1];
        const T bx = next[0] - here[0], by = next[1] - here[1];
        using std::sqrt;
        const T c = ax * by - ay * bx;
        if (!(c > 0.0)) return false;
        const T sine = c / sqrt((ax * ax + ay * ay) * (bx * bx + by * by));
        residual[0] = sine < margin ? kBarrierWeight * (margin - sine) / sine : T(0.0);
        return true;
    }
};

// beta(|e| / |e_r|) on one edge, so that an edge cannot shrink to a point (which keeps every
// corner's sine and so escapes CornerBarrier).
struct EdgeBarrier {
    double length;  // |e_r|
    double margin;
    template <class T>
    bool operator()(const T* p, const T* q, T* residual) const {
        using std::sqrt;
        const T dx = q[0] - p[0], dy = q[1] - p[1];
        const T squared = dx * dx + dy * dy;
        if (!(squared > 0.0)) return false;
        const T ratio = sqrt(squared) / length;
        residual[0] = ratio < margin ? kBarrierWeight * (margin - ratio) / ratio : T(0.0);
        return true;
    }
};

}  // namespace tesswave::fit_detail
