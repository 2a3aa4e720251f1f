"""py_trees behaviours: perception, approach, bypass, search, safety guard."""
