"""Two-sided quantiles of the standard normal distribution, for intervals of value +- z sigma."""

NORMAL_QUANTILE_95 = 1.959963984540054
"""z of a two-sided 95 % interval: Phi^-1(0.975)."""
NORMAL_QUANTILE_99 = 2.5758293035489004
"""z of a two-sided 99 % interval: Phi^-1(0.995) (the bound MATLAB's ``resid`` draws)."""
