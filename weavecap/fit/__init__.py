"""The joint fit of §6 (Wu et al. 2025): Adam on the continuous parameters through the
differentiable forward model, simulated annealing on the discrete ones."""
