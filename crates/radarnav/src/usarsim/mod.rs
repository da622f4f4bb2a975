//! A USARSim server (DESIGN §8): clients written for USARSim's text protocol on TCP port
//! 3000 (the thesis' and RoboCup Rescue's) connect, place a P3AT each and drive it, and
//! receive its sensors' scans as `RangeScanner` messages, its ground truth, odometry and
//! status. [`protocol`] parses and formats lines, [`session`] is one client's robot,
//! [`server`] moves the lines over TCP in real time (or at a set speed factor).

pub mod protocol;
pub mod server;
pub mod session;
