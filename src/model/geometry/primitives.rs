//! Mass properties of the URDF primitives in closed form (SKELETON: issue 5 fills it in).
