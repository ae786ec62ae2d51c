//! Scene formats besides raylab's own TOML: the report's XML style.

pub mod report_xml;

use raylab::Registry;

/// Registers every scene format.
pub fn register(r: &mut Registry) {
    r.add_format(report_xml::format());
}
