"""Identification: the calibration problem, what is estimated, identifiability, priors, and the
solvers (least squares, robust ridge with IGG3 weights, genetic algorithm, particle swarm, BP
network) that estimate the parameter errors."""
