//! Integration tests of the scan crate.

mod calib;
mod calib_real;
mod chessboard;
mod circles;
mod common;
mod decode;
mod eval;
mod fisheye;
mod graycode;
mod markers;
mod pnp;
mod label;
mod label_board;
mod synth;
mod triangulate;
mod undistort;
