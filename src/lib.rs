pub use hair_sim;
