//! Named choices: the macro that makes a setting's mode a unit enum whose serde form,
//! `Display` and `FromStr` are its names (with `NAMES`, `ALL`, `name()`, `from_name()`),
//! and the words that list them. Below the recipe and the generators, so both can use it
//! without importing each other.

/// `names` as words: `a`, `a or b`, `a, b or c`.
pub fn one_of(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [one] => one.to_string(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

/// Defines a recipe mode: a unit enum whose serde form, [`std::fmt::Display`] and
/// [`std::str::FromStr`] are its names, with `NAMES`, `ALL`, `name()` and `from_name()`.
macro_rules! mode {
    (
        $(#[$meta:meta])*
        $name:ident, key $key:literal, default $default:ident {
            $($(#[$vmeta:meta])* $variant:ident = $text:literal,)+
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        pub enum $name {
            $($(#[$vmeta])* #[serde(rename = $text)] $variant,)+
        }

        impl $name {
            /// The recipe key this mode is the value of.
            pub const KEY: &'static str = $key;
            /// The names, in the order of the variants.
            pub const NAMES: &'static [&'static str] = &[$($text),+];
            /// Every variant, in order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The name the recipe gives this value.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text,)+
                }
            }

            /// The value called `name`.
            pub fn from_name(name: &str) -> Option<Self> {
                match name {
                    $($text => Some($name::$variant),)+
                    _ => None,
                }
            }
        }

        impl Default for $name {
            fn default() -> Self {
                $name::$default
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $name {
            type Err = $crate::error::Error;

            /// Errors name the key and list the names.
            fn from_str(s: &str) -> $crate::error::Result<Self> {
                $name::from_name(s).ok_or_else(|| {
                    $crate::error::Error::Recipe(format!(
                        "`{}` is `{}`; use {}",
                        $key,
                        $crate::diagnostic::quote(s),
                        $crate::named::one_of($name::NAMES)
                    ))
                })
            }
        }
    };
}
/// The macro, for the recipe's modes ([`crate::recipe::modes`]) and the least-cost
/// generator's own ([`crate::grow::least_cost`]).
pub(crate) use mode;
