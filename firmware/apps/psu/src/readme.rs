//! The README's generated section.
