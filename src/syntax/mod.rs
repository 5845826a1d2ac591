//! Syntax: `.surf` text → pest parse tree → owned AST in which every node carries its span.
//! Knows nothing of meaning (that is `sema`) or of meshing.
