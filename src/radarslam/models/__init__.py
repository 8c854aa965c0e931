"""Motion and measurement models with analytic Jacobians."""
