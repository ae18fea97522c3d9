#include "bo/acquisition.hpp"

#include <cmath>

namespace maptune::bo {

namespace {
const double kInvSqrt2Pi = 1.0 / std::sqrt(2.0 * M_PI);
const double kLogSqrt2Pi = 0.5 * std::log(2.0 * M_PI);

double normal_pdf(double z) { return kInvSqrt2Pi * std::exp(-0.5 * z * z); }
double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Φ(z) / h(z) = d log h / dz, asymptotic for very negative z.
double dlog_h(double z) {
    if (z > -12.0) return normal_cdf(z) / std::exp(log_h(z));
    const double z2 = z * z;
    const double z4 = z2 * z2;
    return -z * (1.0 - 1.0 / z2 + 3.0 / z4 - 15.0 / (z4 * z2)) /
           (1.0 - 3.0 / z2 + 15.0 / z4 - 105.0 / (z4 * z2));
}
}  // namespace

std::string to_string(Acquisition a) {
    switch (a) {
        case Acquisition::ucb:
            return "ucb";
        case Acquisition::ucb_schedule:
            return "ucb_schedule";
        case Acquisition::ei:
            return "ei";
        case Acquisition::log_ei:
            return "log_ei";
    }
    return "unknown";
}

std::optional<Acquisition> acquisition_from_string(const std::string& name) {
    for (auto a :
         {Acquisition::ucb, Acquisition::ucb_schedule, Acquisition::ei, Acquisition::log_ei}) {
        if (to_string(a) == name) return a;
    }
    return std::nullopt;
}

double srinivas_kappa(int dim, double t, double delta, double scale) {
    const double beta = 2.0 * std::log(dim * t * t * M_PI * M_PI / (6.0 * delta));
    return std::sqrt(std::max(scale * beta, 0.0));
}

double log_h(double z) {
    // Direct form is accurate down to z ≈ −12 (cancellation ~ z² ulp, erfc keeps its tail).
    if (z > -12.0) return std::log(normal_pdf(z) + z * normal_cdf(z));
    // h(z) = φ(z)/z² (1 − 3/z² + 15/z⁴ − 105/z⁶ …) for z → −∞ (Mills ratio expansion).
    const double z2 = z * z;
    const double z4 = z2 * z2;
    return -0.5 * z2 - kLogSqrt2Pi - std::log(z2) +
           std::log1p(-3.0 / z2 + 15.0 / z4 - 105.0 / (z4 * z2));
}

Eigen::VectorXd acquisition_values(const AcquisitionContext& ctx, const Eigen::VectorXd& mean,
                                   const Eigen::VectorXd& variance) {
    const Eigen::ArrayXd sigma = variance.array().sqrt();
    Eigen::VectorXd out(mean.size());
    for (Eigen::Index i = 0; i < mean.size(); ++i) {
        const double s = sigma(i);
        switch (ctx.kind) {
            case Acquisition::ucb:
            case Acquisition::ucb_schedule:
                out(i) = mean(i) + ctx.kappa * s;
                break;
            case Acquisition::ei: {
                const double z = (mean(i) - ctx.incumbent) / s;
                out(i) = s * (normal_pdf(z) + z * normal_cdf(z));
                break;
            }
            case Acquisition::log_ei: {
                const double z = (mean(i) - ctx.incumbent) / s;
                out(i) = std::log(s) + log_h(z);
                break;
            }
        }
    }
    return out;
}

double acquisition_value(const AcquisitionContext& ctx, const gp::PointPrediction& p,
                         Eigen::VectorXd* gradient) {
    const double s = std::sqrt(p.variance);
    const Eigen::VectorXd ds = p.variance_gradient / (2.0 * s);
    switch (ctx.kind) {
        case Acquisition::ucb:
        case Acquisition::ucb_schedule:
            if (gradient != nullptr) *gradient = p.mean_gradient + ctx.kappa * ds;
            return p.mean + ctx.kappa * s;
        case Acquisition::ei: {
            const double z = (p.mean - ctx.incumbent) / s;
            // dEI = Φ(z) dμ + φ(z) dσ.
            if (gradient != nullptr)
                *gradient = normal_cdf(z) * p.mean_gradient + normal_pdf(z) * ds;
            return s * (normal_pdf(z) + z * normal_cdf(z));
        }
        case Acquisition::log_ei: {
            const double z = (p.mean - ctx.incumbent) / s;
            if (gradient != nullptr) {
                const Eigen::VectorXd dz = (p.mean_gradient - z * ds) / s;
                *gradient = ds / s + dlog_h(z) * dz;
            }
            return std::log(s) + log_h(z);
        }
    }
    return 0.0;
}

}  // namespace maptune::bo
