"""Chemistry on snapo_ode: Cantera-YAML kinetics in JAX, stiff reactors in Diffrax, the pharma chain."""
