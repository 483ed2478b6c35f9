"""The twin: firmware and MuJoCo stepped together, the judge, a trial, its results."""
