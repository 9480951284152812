"""Input/output at the edges: configs, units, result files. Only this package writes files."""
