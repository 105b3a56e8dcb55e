//! softshadow-pcss
