//! Compiler: checked surfaces → hash-consed IR (folded as it is built) → register tape,
//! verified before it runs; a readable listing of the tape.
