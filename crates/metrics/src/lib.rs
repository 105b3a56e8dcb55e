//! softshadow-metrics
