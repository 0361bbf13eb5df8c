"""Material textures: procedural generators, mip chains for normal and roughness data, and
the offline baking of mask blends (RTR4 §9.13, "Blending and Filtering Materials")."""
