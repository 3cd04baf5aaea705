//! Sampling directions uniformly in the solid angle of triangles and rectangles.
