//! softshadow facade
