//! Linear radiance images and their 8-bit sRGB encoding.
