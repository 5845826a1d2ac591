//! Diagnostics as data (code, severity, spans, labels, help) and their rendering through
//! codespan-reporting, in one place.
