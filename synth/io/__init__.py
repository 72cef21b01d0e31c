"""Input and output: pose files in; URDF, STL and linkage.json out; reading an output directory back."""
