//! softshadow-reference
