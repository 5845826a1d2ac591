//! Evaluator: runs a verified tape for value, and value + gradient (automatic
//! differentiation), at one point or a batch of points.
