"""The model and its proof: parameters (Table 3), the analytic Lagrange equations, the symbolic derivation, the MuJoCo model, the cross-check and the linearisation."""
