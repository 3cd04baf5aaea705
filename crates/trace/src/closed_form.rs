//! Exact irradiance from polygonal emitters (Lambert, Arvo 1995).
