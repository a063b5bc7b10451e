"""The ground floor: errors, files, units and the numerics every layer shares."""
