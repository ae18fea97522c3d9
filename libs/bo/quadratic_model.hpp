#pragma once
// A quadratic response surface for the optimizer's quadratic steps (issue 15):
// q(u) = c + gᵀh + ½ hᵀ A h, h = u − centre, fitted by least squares to all observations.
// Over the whole box it smooths the ripples of a multi-modal objective into the bowl they sit
// on (Rastrigin, Griewank, Levy), and near the incumbent it gives a curvature-scaled step along
// ill-conditioned axes (ellipsoid, Dixon-Price), both of which a stationary GP, reverting to its
// prior mean away from the data, does not extrapolate. The cross curvatures (A off its
// diagonal) are there for oblique valleys (a rotated ellipsoid, Trid, Zakharov), which a
// separable surface points along the axes; whether the data support them is decided by
// leave-one-out error, since d(d − 1)/2 of them are more than a short run's points.

#include <Eigen/Core>
#include <optional>

namespace maptune::bo {

struct QuadraticModel {
    Eigen::VectorXd centre;
    double c = 0.0;
    Eigen::VectorXd g;  // slope per dimension at the centre
    Eigen::MatrixXd A;  // curvatures, symmetric; diagonal for a separable model

    double value(const Eigen::VectorXd& u) const;
    bool separable() const;
};

// Least squares on the columns of u (d×n) and their values y, the diagonal curvatures
// penalized by ridge × n (so that fewer than 2d + 1 points still give a model, the curvatures
// pulled to 0). With cross_terms, the cross curvatures enter under a ridge (1e-4 … 1 × n,
// decades) when one predicts the left-out values better than the separable model (exact
// leave-one-out error of each ridge regression; the separable model wins ties); without, or
// beyond 16 dimensions (136 or more cross terms; at 16 a fit on 1 000 points already takes
// 51 ms), the model is separable.
// Empty with fewer than d + 1 points or non-finite input.
std::optional<QuadraticModel> fit_quadratic(const Eigen::MatrixXd& u, const Eigen::VectorXd& y,
                                            const Eigen::VectorXd& centre, double ridge = 1e-6,
                                            bool cross_terms = true);

// The maximizer inside [lo, hi] of the model with every eigenvalue of A capped at −1e-6 of the
// largest magnitude. A direction the fit calls convex or flat thus moves up its slope to the
// box's face, as a first-order step would (not to the far face of an upward parabola, trusting
// the extrapolation where it is least supported), and stays put where its slope is negligible.
// Exact for the capped (concave) model: a primal active-set method over the box's faces.
Eigen::VectorXd maximize_in_box(const QuadraticModel& model, const Eigen::VectorXd& lo,
                                const Eigen::VectorXd& hi);

}  // namespace maptune::bo
