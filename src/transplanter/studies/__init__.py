"""Many trials: grids, backends, sweeps, tuning, calibration, statistics, plots."""
