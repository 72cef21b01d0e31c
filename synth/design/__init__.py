"""Physical design of a linkage (mounts, bars, hubs, pins, sizes) and its collision-free search."""
