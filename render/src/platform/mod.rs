//! What the machine offers the hot loops: the processor's vector instructions, huge pages for
//! arrays read at random, and fetching data into the cache ahead of its use.

pub mod cpu;
pub mod huge_pages;
pub mod prefetch;
