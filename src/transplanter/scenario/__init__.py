"""The scenario: its schema, its assembly into the machine and the scene, the preflight."""
