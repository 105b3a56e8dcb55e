//! softshadow-hard
