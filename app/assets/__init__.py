"""Procedural asset generators that write the meshes under ``scenes/meshes``."""
