"""Direction geometry shared by the stages: unit vectors and plane bases, normal clustering, and
arrangements of great circles on S^2 and of points on S^1."""
