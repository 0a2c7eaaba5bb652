"""Pictures and motion for people: a rig drawn to a PNG, the review page's thumbnails, a BVH pose."""
