#pragma once
// Acquisition functions on a GP posterior, all to be maximized, with analytic gradients for
// the L-BFGS-B polish. The GP models the objective in "larger is better" orientation.

#include <Eigen/Core>
#include <optional>
#include <string>

#include "gp/gaussian_process.hpp"

namespace maptune::bo {

enum class Acquisition {
    ucb,           // μ + κσ with fixed κ (the thesis: κ = 5)
    ucb_schedule,  // μ + κ_t σ, κ_t² = scale · 2 log(d t² π² / (6δ)) (Srinivas et al. 2010)
    ei,            // expected improvement over the incumbent
    log_ei,        // log of EI computed stably (Ament et al. 2023): same argmax, no flat zeros
};

std::string to_string(Acquisition a);
std::optional<Acquisition> acquisition_from_string(const std::string& name);

struct AcquisitionContext {
    Acquisition kind = Acquisition::log_ei;
    double kappa = 5.0;      // UCB exploration weight (already scheduled for ucb_schedule)
    double incumbent = 0.0;  // best (fantasized) value so far, for EI
};

// κ_t of the Srinivas schedule at iteration t (1-based) in d dimensions.
double srinivas_kappa(int dim, double t, double delta, double scale);

// log(φ(z) + z Φ(z)), accurate for very negative z.
double log_h(double z);

Eigen::VectorXd acquisition_values(const AcquisitionContext& ctx, const Eigen::VectorXd& mean,
                                   const Eigen::VectorXd& variance);
double acquisition_value(const AcquisitionContext& ctx, const gp::PointPrediction& p,
                         Eigen::VectorXd* gradient);

}  // namespace maptune::bo
