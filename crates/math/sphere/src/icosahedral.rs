//! Icosahedral geodesic triangle hierarchy (levels 0–7), as in
//! `spherical-wavelets-triple-product-2006.txt` §3.1.
//! (Owned by the sphere helper.)
