pub const PLACEHOLDER: &str = "";
