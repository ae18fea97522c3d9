#include "bo/quadratic_model.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>

namespace maptune::bo {

double SeparableQuadratic::value(const Eigen::VectorXd& u) const {
    const Eigen::ArrayXd h = (u - centre).array();
    return c + (g.array() * h).sum() + 0.5 * (a.array() * h.square()).sum();
}

std::optional<SeparableQuadratic> fit_separable_quadratic(const Eigen::MatrixXd& u, const Eigen::VectorXd& y,
                                                          const Eigen::VectorXd& centre, double ridge) {
    const Eigen::Index d = u.rows();
    const Eigen::Index n = u.cols();
    if (n < d + 1 || y.size() != n || centre.size() != d || !y.allFinite() || !u.allFinite()) return std::nullopt;
    // Steps and values scaled to order one, so that one ridge means the same for every box and
    // objective.
    Eigen::MatrixXd steps = u.colwise() - centre;
    double s = std::sqrt(steps.squaredNorm() / static_cast<double>(n * d));
    if (!(s > 0)) s = 1.0;
    steps /= s;
    const double y_mean = y.mean();
    double y_scale = std::sqrt((y.array() - y_mean).square().mean());
    if (!(y_scale > 0)) y_scale = 1.0;

    // Coefficients: constant, d slopes, d curvatures.
    Eigen::MatrixXd design(n, 1 + 2 * d);
    design.col(0).setOnes();
    design.middleCols(1, d) = steps.transpose();
    design.rightCols(d) = 0.5 * steps.transpose().array().square();
    Eigen::MatrixXd normal = design.transpose() * design;
    const auto nn = static_cast<double>(n);
    // The constant and the slopes get a tiny ridge only: d + 1 points determine them first.
    normal.diagonal().head(1 + d).array() += 1e-9 * nn;
    normal.diagonal().tail(d).array() += ridge * nn;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
    if (ldlt.info() != Eigen::Success) return std::nullopt;
    const Eigen::VectorXd theta =
        ldlt.solve(design.transpose() * ((y.array() - y_mean) / y_scale).matrix());
    if (!theta.allFinite()) return std::nullopt;

    SeparableQuadratic m;
    m.centre = centre;
    m.c = y_mean + y_scale * theta(0);
    m.g = theta.segment(1, d) * (y_scale / s);
    m.a = theta.tail(d) * (y_scale / (s * s));
    return m;
}

Eigen::VectorXd maximize_in_box(const SeparableQuadratic& model, const Eigen::VectorXd& lo,
                                const Eigen::VectorXd& hi) {
    // Convex and flat dimensions get a curvature of −1e-6 of the largest: up their slope to the
    // face unless the slope is negligible (a zero slope stays put rather than jump on noise).
    const double floor = -1e-6 * model.a.cwiseAbs().maxCoeff();
    Eigen::VectorXd u = model.centre;
    for (Eigen::Index j = 0; j < u.size(); ++j) {
        const double a = std::min(model.a(j), floor);
        if (a < 0) {
            u(j) -= model.g(j) / a;
        } else if (model.g(j) != 0) {
            u(j) = model.g(j) > 0 ? hi(j) : lo(j);
        }
        u(j) = std::min(std::max(u(j), lo(j)), hi(j));
    }
    return u;
}

}  // namespace maptune::bo
