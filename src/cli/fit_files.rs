//! `lipmap fit --model … --landmarks …`: the headless files-in, files-out fit.
//! (Being written by the fitting work; wired into main.rs by the lead.)
