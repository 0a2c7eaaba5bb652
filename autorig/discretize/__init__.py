"""Discretization: the mesh's distance field, its medial spheres and the graph that joins them."""
