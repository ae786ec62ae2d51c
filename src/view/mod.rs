//! `raylab view`: the live view in the browser (feature `view`). A local web page shows the
//! render as it progresses (a coarse preview, then tiles as they finish, refined pass by pass),
//! offers the quality knobs as controls (any integrator's, by their roles), restarts the render
//! when a control or the scene file changes, and explains any pixel: click it to see its ray tree
//! (the data of `raylab trace --json`) beside the image and its rays drawn over it.
//!
//! - [`session`]: the render thread, the displayed pixels and the status.
//! - [`knobs`]: the controls and how the page's settings become load overrides.
//! - [`overlay`]: an explained sample's rays as marks over the image.
//! - [`http`]: the routes (127.0.0.1 only, a random token, embedded page in `page/`).
//! - [`server`]: a small HTTP/1.1 server over `std::net`, bounded in everything a client sends.

pub mod http;
pub mod knobs;
pub mod overlay;
pub mod server;
pub mod session;
