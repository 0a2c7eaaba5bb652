"""Input: reading a mesh file and its look, checking it, and the working copy the stages share."""
