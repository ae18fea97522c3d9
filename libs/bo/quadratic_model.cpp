#include "bo/quadratic_model.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace maptune::bo {

double QuadraticModel::value(const Eigen::VectorXd& u) const {
    const Eigen::VectorXd h = u - centre;
    return c + g.dot(h) + 0.5 * h.dot(A * h);
}

bool QuadraticModel::separable() const {
    return (A - Eigen::MatrixXd(A.diagonal().asDiagonal())).isZero(0.0);
}

namespace {

struct RidgeFit {
    Eigen::VectorXd theta;
    double loo = std::numeric_limits<double>::infinity();  // leave-one-out mean squared error
};

// Least squares with a penalty per coefficient, and its exact leave-one-out error
// (residual_i / (1 − hat_ii)). gram = XᵀX, shared by the fits of one design under several ridges.
std::optional<RidgeFit> ridge_fit(const Eigen::MatrixXd& X, const Eigen::MatrixXd& gram,
                                  const Eigen::VectorXd& y, const Eigen::VectorXd& penalty) {
    Eigen::MatrixXd normal = gram;
    normal.diagonal() += penalty;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
    if (ldlt.info() != Eigen::Success) return std::nullopt;
    RidgeFit fit;
    fit.theta = ldlt.solve(X.transpose() * y);
    if (!fit.theta.allFinite()) return std::nullopt;
    const Eigen::MatrixXd z = ldlt.solve(X.transpose());
    const Eigen::ArrayXd hat = (X.array() * z.transpose().array()).rowwise().sum();
    const Eigen::ArrayXd residual = (y - X * fit.theta).array();
    if ((1.0 - hat).minCoeff() > 1e-9) fit.loo = (residual / (1.0 - hat)).square().mean();
    return fit;
}

}  // namespace

std::optional<QuadraticModel> fit_quadratic(const Eigen::MatrixXd& u, const Eigen::VectorXd& y,
                                            const Eigen::VectorXd& centre, double ridge,
                                            bool cross_terms) {
    const Eigen::Index d = u.rows();
    const Eigen::Index n = u.cols();
    if (n < d + 1 || y.size() != n || centre.size() != d || !y.allFinite() || !u.allFinite())
        return std::nullopt;
    // Steps and values scaled to order one, so that one ridge means the same for every box and
    // objective.
    Eigen::MatrixXd steps = u.colwise() - centre;
    double s = std::sqrt(steps.squaredNorm() / static_cast<double>(n * d));
    if (!(s > 0)) s = 1.0;
    steps /= s;
    const double y_mean = y.mean();
    double y_scale = std::sqrt((y.array() - y_mean).square().mean());
    if (!(y_scale > 0)) y_scale = 1.0;
    const Eigen::VectorXd target = (y.array() - y_mean) / y_scale;

    // Coefficients: constant, d slopes, d curvatures, then the cross curvatures j < k.
    const Eigen::Index cross = (cross_terms && d > 1 && d <= 16) ? d * (d - 1) / 2 : 0;
    Eigen::MatrixXd design(n, 1 + 2 * d + cross);
    design.col(0).setOnes();
    design.middleCols(1, d) = steps.transpose();
    design.middleCols(1 + d, d) = 0.5 * steps.transpose().array().square();
    for (Eigen::Index j = 0, col = 1 + 2 * d; cross > 0 && j < d; ++j)
        for (Eigen::Index k = j + 1; k < d; ++k, ++col)
            design.col(col) = (steps.row(j).array() * steps.row(k).array()).transpose();
    const auto nn = static_cast<double>(n);
    // The constant and the slopes get a tiny ridge only: d + 1 points determine them first.
    Eigen::VectorXd penalty(design.cols());
    penalty.head(1 + d).setConstant(1e-9 * nn);
    penalty.segment(1 + d, d).setConstant(ridge * nn);

    // Separable unless some ridge on the cross curvatures predicts the left-out values better:
    // with few points or ripples that the cross terms would only chase, it does not.
    const Eigen::MatrixXd separable = design.leftCols(1 + 2 * d);
    auto best =
        ridge_fit(separable, separable.transpose() * separable, target, penalty.head(1 + 2 * d));
    if (!best) return std::nullopt;
    Eigen::Index used = 1 + 2 * d;
    const Eigen::MatrixXd gram =
        cross > 0 ? Eigen::MatrixXd(design.transpose() * design) : Eigen::MatrixXd();
    for (double lambda = 1e-4; cross > 0 && lambda <= 1.0 + 1e-12; lambda *= 10.0) {
        penalty.tail(cross).setConstant(lambda * nn);
        auto fit = ridge_fit(design, gram, target, penalty);
        if (fit && fit->loo < best->loo) {
            best = std::move(fit);
            used = design.cols();
        }
    }

    QuadraticModel m;
    m.centre = centre;
    m.c = y_mean + y_scale * best->theta(0);
    m.g = best->theta.segment(1, d) * (y_scale / s);
    m.A = Eigen::MatrixXd::Zero(d, d);
    m.A.diagonal() = best->theta.segment(1 + d, d) * (y_scale / (s * s));
    if (used > 1 + 2 * d) {
        for (Eigen::Index j = 0, col = 1 + 2 * d; j < d; ++j)
            for (Eigen::Index k = j + 1; k < d; ++k, ++col)
                m.A(j, k) = m.A(k, j) = best->theta(col) * (y_scale / (s * s));
    }
    return m;
}

Eigen::VectorXd maximize_in_box(const QuadraticModel& model, const Eigen::VectorXd& lo,
                                const Eigen::VectorXd& hi) {
    const Eigen::Index d = model.centre.size();
    // Convex and flat directions get a curvature of −1e-6 of the largest: up their slope to the
    // face unless the slope is negligible (a zero slope stays put rather than jump on noise).
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(model.A);
    const double floor = -1e-6 * eig.eigenvalues().cwiseAbs().maxCoeff();
    const Eigen::MatrixXd A =
        floor < 0
            ? Eigen::MatrixXd(eig.eigenvectors() * eig.eigenvalues().cwiseMin(floor).asDiagonal() *
                              eig.eigenvectors().transpose())
            : Eigen::MatrixXd::Zero(d, d);
    const Eigen::VectorXd l = lo - model.centre, u = hi - model.centre;
    Eigen::VectorXd h = Eigen::VectorXd::Zero(d).cwiseMax(l).cwiseMin(u);
    if (!(floor < 0)) {
        // No curvature at all: a first-order step to the faces the slope points at.
        for (Eigen::Index j = 0; j < d; ++j)
            if (model.g(j) != 0) h(j) = model.g(j) > 0 ? u(j) : l(j);
        return model.centre + h;
    }
    // Primal active set for the concave quadratic over the box: maximize over the free
    // coordinates with the bound ones fixed, walk towards that maximizer until a face blocks,
    // and free a bound coordinate whose gradient points back into the box. Every step raises the
    // model, so the loop ends; the cap on rounds only guards against rounding cycles.
    std::vector<int> state(static_cast<std::size_t>(d), 0);  // 0 free, −1 at lo, +1 at hi
    for (int round = 0; round < 10 * static_cast<int>(d) + 10; ++round) {
        std::vector<Eigen::Index> free;
        for (Eigen::Index j = 0; j < d; ++j)
            if (state[static_cast<std::size_t>(j)] == 0) free.push_back(j);
        bool blocked = false;
        if (!free.empty()) {
            const auto f = static_cast<Eigen::Index>(free.size());
            Eigen::MatrixXd aff(f, f);
            Eigen::VectorXd rhs(f);
            const Eigen::VectorXd grad = model.g + A * h;
            for (Eigen::Index a = 0; a < f; ++a) {
                rhs(a) = grad(free[a]);
                for (Eigen::Index b = 0; b < f; ++b) aff(a, b) = -A(free[a], free[b]);
            }
            // Newton step on the free coordinates: −A_FF step = gradient_F.
            const Eigen::VectorXd step = aff.ldlt().solve(rhs);
            double alpha = 1.0;
            Eigen::Index blocking = -1;
            int side = 0;
            for (Eigen::Index a = 0; a < f; ++a) {
                const Eigen::Index j = free[a];
                if (step(a) > 0 && h(j) + step(a) > u(j) && (u(j) - h(j)) / step(a) < alpha) {
                    alpha = (u(j) - h(j)) / step(a);
                    blocking = j;
                    side = 1;
                } else if (step(a) < 0 && h(j) + step(a) < l(j) &&
                           (l(j) - h(j)) / step(a) < alpha) {
                    alpha = (l(j) - h(j)) / step(a);
                    blocking = j;
                    side = -1;
                }
            }
            for (Eigen::Index a = 0; a < f; ++a) h(free[a]) += alpha * step(a);
            if (blocking >= 0) {
                state[static_cast<std::size_t>(blocking)] = side;
                h(blocking) = side > 0 ? u(blocking) : l(blocking);
                blocked = true;
            }
        }
        if (blocked) continue;
        // At the free coordinates' maximizer: release the bound coordinate whose gradient
        // points into the box the most, or stop.
        const Eigen::VectorXd grad = model.g + A * h;
        Eigen::Index release = -1;
        double worst = 0.0;
        for (Eigen::Index j = 0; j < d; ++j) {
            const double pull = -state[static_cast<std::size_t>(j)] * grad(j);  // > 0: wants inside
            if (state[static_cast<std::size_t>(j)] != 0 && pull > worst) {
                worst = pull;
                release = j;
            }
        }
        if (release < 0) break;
        state[static_cast<std::size_t>(release)] = 0;
    }
    return (model.centre + h).cwiseMax(lo).cwiseMin(hi);
}

}  // namespace maptune::bo
