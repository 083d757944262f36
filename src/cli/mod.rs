//! The program's subcommands, one module per subcommand or group: each holds its flags (clap)
//! and a thin body that calls the library.

pub mod decode;
pub mod encode;
pub mod encode_warped;
pub mod figures;
pub mod inspect;
pub mod layout;
pub mod parse;
pub mod subset;
pub mod synth;
pub mod tradeoff;
pub mod validate;
