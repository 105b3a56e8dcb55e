//! softshadow-bench
