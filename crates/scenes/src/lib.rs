//! softshadow-scenes
