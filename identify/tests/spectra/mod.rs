//! FRF estimation: Welch H1/H2/Hv, streamed, impacts, chirps, real data.

mod basic;
mod real;
mod stream;
mod systems;
