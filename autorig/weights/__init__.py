"""Skinning: bone heat weights, which bones of a user's skeleton heat the surface, and work begun ahead."""
