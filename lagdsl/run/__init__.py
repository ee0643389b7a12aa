"""Running generated code: the C toolchain and cache, the two backends' runners, outputs."""
