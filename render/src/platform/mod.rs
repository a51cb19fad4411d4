//! What the machine offers the hot loops: the processor's vector instructions, huge pages for
//! arrays read at random, fetching data into the cache ahead of its use, and Open Image Denoise
//! when the machine has it.

pub mod cpu;
pub mod huge_pages;
pub mod oidn;
pub mod prefetch;
