//! The marching method of E. Hartmann (paper Sect. 2): an advancing front of near-equilateral
//! triangles over a surface it sees only through the `Surface` oracle and surfacepoint.
