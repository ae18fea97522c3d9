#pragma once
// A separable quadratic response surface for the optimizer's quadratic steps (issue 15):
// q(u) = c + Σ_j g_j h_j + ½ a_j h_j², h = u − centre, fitted by least squares to all
// observations. Over the whole box it smooths the ripples of a multi-modal objective into
// the bowl they sit on (Rastrigin, Griewank, Levy), and near the incumbent it gives a
// curvature-scaled step along ill-conditioned axes (ellipsoid, Dixon-Price), both of which a
// stationary GP, reverting to its prior mean away from the data, does not extrapolate.

#include <Eigen/Core>
#include <optional>

namespace maptune::bo {

struct SeparableQuadratic {
    Eigen::VectorXd centre;
    double c = 0.0;
    Eigen::VectorXd g;  // slope per dimension at the centre
    Eigen::VectorXd a;  // curvature per dimension

    double value(const Eigen::VectorXd& u) const;
};

// Least squares on the columns of u (d×n) and their values y, the curvatures penalized by
// ridge × n (so that fewer than 2d + 1 points still give a model, the curvatures pulled to 0).
// Empty with fewer than d + 1 points or non-finite input.
std::optional<SeparableQuadratic> fit_separable_quadratic(const Eigen::MatrixXd& u, const Eigen::VectorXd& y,
                                                          const Eigen::VectorXd& centre, double ridge = 1e-6);

// The maximizer inside [lo, hi] of the model with every curvature capped at −1e-6 of the
// largest: per dimension the vertex −g_j / a_j, clamped to the box. A dimension the fit calls
// convex or flat thus moves up its slope to the box's face, as a first-order step would (not
// to the far face of an upward parabola, trusting the extrapolation where it is least
// supported), and stays put where its slope is negligible.
Eigen::VectorXd maximize_in_box(const SeparableQuadratic& model, const Eigen::VectorXd& lo,
                                const Eigen::VectorXd& hi);

}  // namespace maptune::bo
