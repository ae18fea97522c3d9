#pragma once
// The optimizer's own description of a search box. The optimizer works in the unit cube u;
// integer parameters are rounded inside the map to the GP's inputs, so the model sees the
// values that are really evaluated (not a continuous proposal rounded afterwards).

#include <Eigen/Core>
#include <string>
#include <vector>

namespace maptune::bo {

struct ParameterSpec {
    std::string name;
    double low = 0.0;
    double high = 1.0;
    bool is_integer = false;  // values low, low+1, ..., high
    bool log_scale = false;   // needs low > 0 (integers: low >= 1)
    // Floats: values are the multiples of step within [low, high] (the resolution the
    // objective sees, e.g. 0.01 for 2 decimals); 0 = continuous.
    double step = 0.0;
};

class SearchSpace {
  public:
    // Throws std::invalid_argument for empty spaces or inconsistent bounds (programmer error).
    explicit SearchSpace(std::vector<ParameterSpec> specs);

    int dim() const { return static_cast<int>(specs_.size()); }
    const std::vector<ParameterSpec>& specs() const { return specs_; }
    bool has_integers() const;
    // Integers or floats with a step: a proposal must be moved onto the grid (snap).
    bool has_grid() const;

    // Unit-cube point -> parameter values (integers exact).
    std::vector<double> to_values(const Eigen::VectorXd& u) const;
    // Parameter values -> unit-cube point (integers at the centre of their bin).
    Eigen::VectorXd from_values(const std::vector<double>& values) const;
    // Unit-cube point -> GP input in [0, 1]^d: identity on continuous dimensions, the
    // normalized rounded value on integer ones.
    Eigen::VectorXd to_model_input(const Eigen::VectorXd& u) const;
    // Moves integer coordinates to the centre of their bin and stepped floats onto their grid
    // (the values the objective will see, canonical u).
    Eigen::VectorXd snap(const Eigen::VectorXd& u) const;
    // Values clamped to bounds and rounded on integer and stepped parameters.
    std::vector<double> canonical(const std::vector<double>& values) const;

  private:
    double transform(int j, double x) const;  // log or identity
    double inverse_transform(int j, double t) const;
    double integer_value(int j, double u) const;
    double grid_value(int j, double x) const;  // nearest multiple of step within the bounds

    std::vector<ParameterSpec> specs_;
};

}  // namespace maptune::bo
