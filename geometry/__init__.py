"""Impeller geometry: camber data, parametric design, ruled surfaces, solids, meshes."""
