#pragma once
// Matern-5/2 kernel with one length scale per input dimension (ARD).
//
// Inputs are columns of a d×n matrix in the unit cube (the GP's caller normalizes); outputs are
// standardized, so the signal variance is close to 1 for a well-fitted model.

#include <Eigen/Core>

namespace maptune::gp {

struct Hyperparameters {
    Eigen::VectorXd length_scales;  // one per input dimension, in unit-cube units
    double signal_variance = 1.0;   // standardized output units squared
    double noise_variance = 1e-4;   // standardized output units squared
    // Extra noise of the observations set_data marks low-fidelity (multi-fidelity estimates
    // from a subset of the pairs), standardized units squared; fitted only when there are such
    // observations, and not part of to_log().
    double low_fidelity_noise = 0.0;

    static Hyperparameters defaults(int dim);
    // Log-space vector [log l_1 .. log l_d, log signal_variance, log noise_variance]: the
    // optimizer works there so that positivity is free and scales are comparable.
    Eigen::VectorXd to_log() const;
    static Hyperparameters from_log(const Eigen::VectorXd& theta);
};

// Squared distances between the columns of a and b after dividing each row by its length scale.
Eigen::MatrixXd scaled_sq_dist(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                               const Eigen::VectorXd& length_scales);

// k(r) = s² (1 + √5 r + 5 r²/3) exp(-√5 r) applied elementwise to squared distances r².
Eigen::MatrixXd matern52_from_sq_dist(const Eigen::MatrixXd& r2, double signal_variance);

// Cross-covariance matrix K(a, b), a: d×n, b: d×m, result n×m (noise not included).
Eigen::MatrixXd matern52(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                         const Hyperparameters& hp);

// Gradient of k(x, x_i) with respect to x for every column x_i of xs: result d×n.
Eigen::MatrixXd matern52_input_gradient(const Eigen::VectorXd& x, const Eigen::MatrixXd& xs,
                                        const Hyperparameters& hp);

}  // namespace maptune::gp
