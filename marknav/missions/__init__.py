"""Missions: schema, YAML loading with line-numbered errors, tree building, the run loop."""
