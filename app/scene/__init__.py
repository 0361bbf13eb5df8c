"""The scene model: what a scene file says, validated, with units and defaults."""
