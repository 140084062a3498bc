//! Simulation of a twin at moving axes against the virtual machine.

mod moving;
