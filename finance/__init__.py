"""Finance on snapo_ode: natural-gas storage and pension-fund ALM."""
