"""Read-offs from the mesh: legs, rump, head, landmarks and the rest pose, measured on the surface."""
