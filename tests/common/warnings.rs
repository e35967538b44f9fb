//! Every warning the test binary logs, collected by a global tracing subscriber, for the tests
//! that check a bad input was warned about (`capture_warnings` first).

use std::sync::{Mutex, Once};

use bevy::log::tracing::{self, Subscriber};
use bevy::log::tracing_subscriber::{self, Layer, layer::SubscriberExt};

/// Every warning logged in this test binary.
pub(crate) static WARNINGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// Collects warnings into [`WARNINGS`].
struct Capture;

impl<S: Subscriber> Layer<S> for Capture {
    fn on_event(&self, event: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
        struct Message(String);
        impl tracing::field::Visit for Message {
            fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
                if field.name() == "message" {
                    self.0 = format!("{value:?}");
                }
            }
        }
        if *event.metadata().level() == tracing::Level::WARN {
            let mut message = Message(String::new());
            event.record(&mut message);
            WARNINGS.lock().unwrap().push(message.0);
        }
    }
}

/// Starts collecting warnings (once per test binary).
pub(crate) fn capture_warnings() {
    static START: Once = Once::new();
    START.call_once(|| {
        tracing::subscriber::set_global_default(tracing_subscriber::registry().with(Capture))
            .expect("no other subscriber in the tests");
    });
}

/// How many warnings so far contain every one of `parts`.
pub(crate) fn warnings_with(parts: &[&str]) -> usize {
    WARNINGS
        .lock()
        .unwrap()
        .iter()
        .filter(|w| parts.iter().all(|p| w.contains(p)))
        .count()
}
